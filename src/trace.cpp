#include "meshmark/trace.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "meshmark/attack.h"
#include "meshmark/closest_point.h"
#include "meshmark/coding.h"
#include "meshmark/detect.h"
#include "meshmark/error.h"
#include "meshmark/histogram.h"
#include "meshmark/variant.h"
#include "meshmark/watermark.h"

namespace meshmark {

const char* trace_status_name(TraceStatus status) {
  switch (status) {
    case TraceStatus::Named:
      return "named";
    case TraceStatus::NoBuyer:
      return "no-buyer";
    case TraceStatus::RegistrationFailed:
      return "registration-failed";
    case TraceStatus::NoCandidates:
      return "no-candidates";
  }
  return "?";
}

namespace {

Resampled measure(const Eigen::MatrixX3d& VL, const Eigen::MatrixX3i& FL,
                  const Eigen::MatrixX3d& VO, const std::vector<std::uint8_t>& carrier,
                  const Eigen::Vector3d& center, double erase) {
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < VO.rows(); ++i)
    if (carrier[i]) rows.push_back(i);
  Eigen::MatrixX3d Q(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) Q.row(k) = VO.row(rows[k]);
  const ClosestPoints cp = closest_points(VL, FL, Q);
  Resampled m;
  m.point = VO;
  m.measured.assign(static_cast<std::size_t>(VO.rows()), 0);
  std::size_t found = 0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (!(cp.distance(k) <= erase)) continue;
    const Eigen::Vector3d q = cp.point.row(k).transpose();
    const Eigen::Vector3d a = VL.row(FL(cp.face[k], 0)), b = VL.row(FL(cp.face[k], 1)),
                          c = VL.row(FL(cp.face[k], 2));
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    const Eigen::Vector3d dir = (Q.row(k).transpose() - center).normalized();
    const double along = dir.dot(n);
    Eigen::Vector3d p = q;
    if (std::abs(along) > 0.1) {
      const Eigen::Vector3d hit = center + dir * ((a - center).dot(n) / along);
      if ((hit - q).norm() <= erase) p = hit;
    }
    m.point.row(rows[k]) = p.transpose();
    m.measured[rows[k]] = 1;
    ++found;
  }
  m.fraction = rows.empty() ? 0 : static_cast<double>(found) / rows.size();
  return m;
}

// The bits (bin order, kErasure for a bin with nothing measured) a group's mark would explain
// best, the fitted attenuation, and each bin's evidence (bin order, a 1 meaning bin bit 1).
std::vector<std::uint8_t> read_bits(const Eigen::MatrixX3d& VO, const Eigen::MatrixX3d& reference,
                                    const std::vector<std::uint8_t>& carrier, const Histogram& h,
                                    const Resampled& m, const std::vector<double>& alpha,
                                    double& gamma, std::vector<BitEvidence>& evidence) {
  const int nb = h.bins - 2;
  std::vector<double> sum0(nb, 0), sum(nb, 0);
  std::vector<int> count(nb, 0);
  for (Eigen::Index i = 0; i < VO.rows(); ++i) {
    if (!carrier[i] || !m.measured[i]) continue;
    const int j = h.bin[i] - 1;
    if (j < 0 || j >= nb) continue;
    const double rho = (m.point.row(i).transpose() - h.center).norm();
    // The reference: the original, or the original processed as the leak seems to have been.
    sum0[j] += ((reference.row(i).transpose() - h.center).norm() - h.rho_min) / h.step - h.bin[i];
    sum[j] += (rho - h.rho_min) / h.step - h.bin[i];
    ++count[j];
  }
  std::vector<double> shift(nb, 0), up(nb, 0), down(nb, 0);
  for (int j = 0; j < nb; ++j) {
    if (!count[j]) continue;
    const double m0 = sum0[j] / count[j];
    shift[j] = (sum[j] - sum0[j]) / count[j];
    up[j] = 0.5 + alpha[j] - m0;  // the shift a 1 asks for
    down[j] = 0.5 - alpha[j] - m0;
  }
  std::vector<std::uint8_t> bits(nb, kErasure);
  gamma = 1;
  for (int round = 0; round < 20; ++round) {
    double num = 0, den = 0;
    for (int j = 0; j < nb; ++j) {
      if (!count[j]) continue;
      bits[j] = std::abs(shift[j] - gamma * up[j]) < std::abs(shift[j] - gamma * down[j]);
      const double e = bits[j] ? up[j] : down[j];
      num += shift[j] * e, den += e * e;
    }
    const double next = den > 0 ? std::clamp(num / den, 0.02, 2.0) : 1.0;
    if (std::abs(next - gamma) < 1e-12) break;
    gamma = next;
  }
  evidence.assign(nb, BitEvidence{});
  for (int j = 0; j < nb; ++j)
    evidence[j] = {shift[j], gamma * up[j], gamma * down[j], count[j], bits[j]};
  return bits;
}

}  // namespace

Resampled resample_at_original(const Eigen::MatrixX3d& VL, const Eigen::MatrixX3i& FL,
                               const Eigen::MatrixX3d& VO, const Eigen::MatrixX3i& FO,
                               const Eigen::Vector3d& center, double erase_distance) {
  const std::vector<std::uint8_t> carrier = carrier_vertices(VO, FO);
  if (VL.rows() == VO.rows() && FL.rows() == FO.rows() && FL == FO) {
    // The same connectivity (noise, quantization, smoothing, a similarity): vertex i is
    // vertex i, measured where it is, unless it moved beyond the erase distance.
    Resampled m;
    m.point = VL;
    m.measured.assign(static_cast<std::size_t>(VO.rows()), 0);
    std::size_t used = 0, found = 0;
    for (Eigen::Index i = 0; i < VO.rows(); ++i) {
      if (!carrier[i]) continue;
      ++used;
      if ((VL.row(i) - VO.row(i)).norm() <= erase_distance) m.measured[i] = 1, ++found;
    }
    m.fraction = used ? static_cast<double>(found) / used : 0;
    return m;
  }
  return measure(VL, FL, VO, carrier, center, erase_distance);
}

TraceResult trace(const Mesh& leaked, const Mesh& original,
                  const std::vector<IssuedCopy>& candidates, const Key& key,
                  const TraceOptions& o) {
  if (!(o.threshold > 0 && o.threshold < 1))
    throw InvalidArgumentError(fmt::format("the threshold {} is out of (0, 1)", o.threshold));
  if (!(o.erase_distance > 0)) throw InvalidArgumentError("the erase distance must be positive");
  TraceResult r;
  const std::string fingerprint = key_fingerprint(key);
  std::vector<IssuedCopy> mine;
  for (const IssuedCopy& c : candidates)
    if (c.key_fingerprint == fingerprint) mine.push_back(c);
  if (mine.empty()) {
    r.status = TraceStatus::NoCandidates;
    r.message = "no copy was issued under this key";
    return r;
  }
  if (o.register_leak) {
    r.registration =
        register_similarity(leaked.V, leaked.F, original.V, original.F, o.registration);
    if (r.registration.status != RegistrationStatus::Registered) {
      r.status = TraceStatus::RegistrationFailed;
      r.message = r.registration.message;
      return r;
    }
  } else {
    r.registration.status = RegistrationStatus::Registered;
    r.registration.message = "in the original's frame (not registered)";
  }
  const Eigen::MatrixX3d VL = r.registration.transform.apply(leaked.V);
  const std::vector<std::uint8_t> carrier = carrier_vertices(original.V, original.F);
  const double diagonal = bounding_box_diagonal(original.V, carrier);

  // Groups of candidates read alike.
  using GroupKey = std::tuple<char, int, int, double, double>;
  std::map<GroupKey, std::vector<std::size_t>> groups;
  for (std::size_t k = 0; k < mine.size(); ++k)
    groups[{mine[k].variant.empty() ? 'D' : mine[k].variant[0], mine[k].bits, mine[k].id_bits,
            mine[k].strength, mine[k].strength_spread}]
        .push_back(k);
  // A leak with the original's faces may have been smoothed: the processing of the original
  // that the leak resembles best (Laplacian smoothing with lambda 0.3, or Taubin, 1 to 40
  // iterations) becomes the reference the shifts are measured from, when it at least halves
  // the RMS distance; its shrinking is then not taken for the mark.
  Eigen::MatrixX3d reference = original.V;
  r.processing = "none";
  if (leaked.V.rows() == original.V.rows() && leaked.F.rows() == original.F.rows() &&
      leaked.F == original.F) {
    auto rms = [&](const Eigen::MatrixX3d& P) { return std::sqrt((VL - P).squaredNorm()); };
    const double unprocessed = rms(original.V);
    double best = unprocessed;
    for (const bool taubin : {false, true}) {
      Mesh current = original;
      for (int k = 1; k <= 40; ++k) {
        current = taubin ? attack_smooth_taubin(current, 1) : attack_smooth_laplacian(current, 1);
        const double e = rms(current.V);
        if (e < best) {
          best = e;
          reference = current.V;
          r.processing = fmt::format("{} smoothing x {}", taubin ? "Taubin" : "Laplacian", k);
        }
      }
    }
    if (!(best < 0.5 * unprocessed)) reference = original.V, r.processing = "none";
  }
  bool first = true;
  for (const auto& [group, members] : groups) {
    const auto& [letter, bits, id_bits, strength, spread] = group;
    const CenterKind kind = parse_variant(std::string(1, letter) + "RS").center;
    const Center center = center_of_mass(original.V, original.F, carrier, kind);
    const Histogram h = build_histogram(original.V, carrier, center.point, bits);
    if (!h.valid()) throw InvalidArgumentError("the original has no histogram");
    const Resampled m = resample_at_original(VL, leaked.F, original.V, original.F, center.point,
                                             o.erase_distance * diagonal);
    double gamma = 1;
    const std::vector<double> alpha = mark_strengths(key, bits, true, strength, spread);
    std::vector<BitEvidence> evidence;
    const std::vector<std::uint8_t> bin_bits =
        read_bits(original.V, reference, carrier, h, m, alpha, gamma, evidence);
    const BitLayout layout = mark_layout(key, bits, true);
    const std::vector<std::uint8_t> read = layout.from_bins(bin_bits);
    IdCodeOptions co;
    co.bits = bits;
    co.id_bits = id_bits;
    const IdCode code(co);
    const CodewordNull null(code, read, key);
    for (const std::size_t k : members) {
      CandidateScore s;
      s.copy = mine[k];
      s.compared = bits;
      const Payload c = code.encode(mine[k].id, key);
      for (int j = 0; j < bits; ++j) s.matches += read[j] <= 1 && read[j] == c.bits[j];
      s.p_value = null.p_value(s.matches);
      s.corrected_p = std::min(1.0, s.p_value * static_cast<double>(mine.size()));
      r.ranking.push_back(s);
    }
    if (first) {
      r.measured_fraction = m.fraction, r.attenuation = gamma, first = false;
      for (int j = 0; j < bits; ++j) {
        BitEvidence e = evidence[layout.bin_of[j]];
        if (layout.whitening[j]) std::swap(e.if_one, e.if_zero);
        e.bit = read[j];
        r.bits.push_back(e);
      }
    }
  }
  std::stable_sort(
      r.ranking.begin(), r.ranking.end(),
      [](const CandidateScore& a, const CandidateScore& b) { return a.p_value < b.p_value; });
  for (const CandidateScore& s : r.ranking)
    if (s.corrected_p < o.threshold) r.named.push_back(s);
  r.status = r.named.empty() ? TraceStatus::NoBuyer : TraceStatus::Named;
  r.message =
      r.named.empty()
          ? fmt::format("no buyer: the best of {} candidates has p = {:.3g} after correction",
                        r.ranking.size(), r.ranking.front().corrected_p)
          : fmt::format(
                "{} named: '{}' (ID {}), p = {:.3g} after correction for {} candidates",
                r.named.size() == 1 ? "one buyer" : fmt::format("{} buyers", r.named.size()),
                r.named[0].copy.buyer, r.named[0].copy.id, r.named[0].corrected_p,
                r.ranking.size());
  return r;
}

}  // namespace meshmark
