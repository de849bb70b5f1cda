// Strength calibration: the strongest mark within the limits, for the payload given, measured
// again here with the metrics' own entry points; the prepared embedder equal to embed(); the
// causes named when nothing fits.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include "meshmark/attacks/attack.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/calibrate.h"
#include "meshmark/metrics/metrics.h"
#include "meshmark/protocol/key.h"
#include "meshmark/protocol/watermark.h"
#include "test_data.h"

namespace meshmark {
namespace {

// Tolerance of re-measuring a distortion the calibration measured: the same computation
// through another entry point, so only rounding may differ.
constexpr double kSameMeasure = 1e-9;

struct Measured {
  double rms = 0, msdm = 0;
};

// A mesh prepared with the default embedding, and a key's coded IDs.
struct CodedOriginal {
  Mesh mesh;
  Key key;
  IdCode code;
  EmbedOptions eo;
  PreparedEmbedder prepared;
  CodedOriginal(const std::string& path, const std::string& key_name)
      : mesh(read_mesh(path)),
        key(derive_key(public_key(), key_name)),
        prepared(mesh.V, mesh.F, eo) {}
};

// The distortion of embedding payload at the calibrated settings, from scratch.
Measured measure_again(const Mesh& mesh, const Payload& payload, EmbedOptions eo,
                       const CalibrateResult& r) {
  eo.strength = r.strength;
  eo.bin_offset = r.bin_offset;
  eo.strengths = r.strengths;
  const EmbedResult w = embed(mesh.V, mesh.F, payload, eo);
  EXPECT_EQ(w.status, EmbedStatus::Embedded) << w.message;
  return {vertex_rms_percent(mesh.V, w.V, mesh.F), msdm(mesh.V, w.V, mesh.F).global};
}

TEST(PreparedEmbedder, GivesWhatEmbedGivesForEveryPayloadAndStrength) {
  const std::string path = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh mesh = read_mesh(path);
  for (const char* v : {"DRS", "VSS", "VRL"}) {
    EmbedOptions eo;
    eo.variant = parse_variant(v);
    const PreparedEmbedder prepared(mesh.V, mesh.F, eo);
    for (int p = 0; p < 3; ++p) {
      eo.strength = 0.02 + 0.01 * p;
      eo.bin_offset = 0.01 * p;
      const Payload payload = calibration_payload(64, 100 + p);
      const EmbedResult a = prepared.embed(payload, eo);
      const EmbedResult b = embed(mesh.V, mesh.F, payload, eo);
      ASSERT_EQ(a.status, b.status) << v;
      EXPECT_EQ(a.rounds, b.rounds) << v;
      EXPECT_TRUE(a.V == b.V) << v << ": the prepared embedding differs";
    }
    EmbedOptions other = eo;
    other.variant = parse_variant("SRS");
    EXPECT_FALSE(prepared.accepts(other));
    EXPECT_THROW(prepared.embed(calibration_payload(64, 1), other), InvalidArgumentError);
  }
}

TEST(Calibrate, EveryPayloadGetsItsStrongestMarkWithinBothLimits) {
  // Per copy: ten coded buyers' words with keyed per-bit strengths, each calibrated for
  // itself; re-measured, every copy meets both limits, and the next strength up (by the
  // search's precision) breaks one unless the distortion already sits at a limit.
  const std::string path = test::closed_binary_ply();
  MESHMARK_REQUIRE(path, "bunny00.off");
  const CodedOriginal original(path, "calibrate-test");
  const auto& [mesh, key, code, eo, prepared] = original;
  CalibrateOptions o;
  o.strengths = [&](double alpha) { return mark_strengths(key, 64, true, alpha, 0.25); };
  int at_limit = 0;
  for (std::uint64_t id = 1000; id < 1010; ++id) {  // consecutive IDs
    const Payload bins = id_bins(code, id, key);
    const CalibrateResult r = calibrate_strength(prepared, bins, eo, o);
    ASSERT_EQ(r.status, CalibrateStatus::Calibrated) << r.message;
    EXPECT_LE(r.evaluations, 10) << "the search should need far fewer embeddings than 14";
    EXPECT_DOUBLE_EQ(r.bin_offset, std::min(eo.bin_offset, r.strength));
    const Measured m = measure_again(mesh, bins, eo, r);
    EXPECT_NEAR(m.rms, r.rms_percent, kSameMeasure);
    EXPECT_NEAR(m.msdm, r.msdm, kSameMeasure);
    EXPECT_LE(m.rms, o.max_rms_percent);
    EXPECT_LE(m.msdm, o.max_msdm);
    const double ratio = std::max(m.rms / o.max_rms_percent, m.msdm / o.max_msdm);
    if (ratio >= 1 - o.precision) {
      ++at_limit;
      continue;
    }
    CalibrateResult up = r;
    up.strength = r.strength * (1 + o.precision);
    up.bin_offset = std::min(eo.bin_offset, up.strength);
    up.strengths = o.strengths(up.strength);
    const Measured next = measure_again(mesh, bins, eo, up);
    EXPECT_TRUE(next.rms > o.max_rms_percent || next.msdm > o.max_msdm)
        << "ID " << id << ": strength " << up.strength << " still fits";
  }
  RecordProperty("at_limit", at_limit);
}

// Steering (CalibrateOptions::steer) changes how the search gets there, not what it stops on:
// on bunny00 (37,706 vertices, MSDM estimated from every 9th vertex's window) the strength of
// each payload is measured in full, within both limits, and the same strongest strength as
// the search that measures every trial in full finds, to kSameStrongest; with fewer full
// measurements in all. Below 16,384 vertices nothing is estimated.
TEST(Calibrate, SteeringMeasuresLessAndStopsWhereTheFullSearchStops) {
  // Two stops of the same rule: each alpha has its distortion within 1 % of the limit (or the
  // limit bracketed to 1 %), and the distortion grows at least as alpha^0.5 there, so each
  // lies within 2 % below the strongest alpha; 3 % leaves room for MSDM's small wiggles.
  constexpr double kSameStrongest = 0.03;
  const std::string path = test::closed_binary_ply();
  MESHMARK_REQUIRE(path, "bunny00.off");
  const CodedOriginal original(path, "steer-test");
  const auto& [mesh, key, code, eo, prepared] = original;
  CalibrateOptions steered, full;
  steered.strengths =
      full.strengths = [&](double alpha) { return mark_strengths(key, 64, true, alpha, 0.25); };
  full.steer = false;
  int measured_steered = 0, measured_full = 0;
  for (std::uint64_t id = 40; id < 43; ++id) {
    const Payload bins = id_bins(code, id, key);
    const CalibrateResult s = calibrate_strength(prepared, bins, eo, steered);
    const CalibrateResult f = calibrate_strength(prepared, bins, eo, full);
    ASSERT_EQ(s.status, CalibrateStatus::Calibrated) << s.message;
    ASSERT_EQ(f.status, CalibrateStatus::Calibrated) << f.message;
    EXPECT_GT(s.estimates, 0);
    EXPECT_GE(s.measurements, 1);
    EXPECT_EQ(f.estimates, 0);
    const Measured m = measure_again(mesh, bins, eo, s);
    EXPECT_NEAR(m.rms, s.rms_percent, kSameMeasure);
    EXPECT_NEAR(m.msdm, s.msdm, kSameMeasure) << "the strength found was not measured in full";
    EXPECT_LE(m.rms, steered.max_rms_percent);
    EXPECT_LE(m.msdm, steered.max_msdm);
    EXPECT_NEAR(s.strength, f.strength, kSameStrongest * f.strength) << "ID " << id;
    measured_steered += s.measurements, measured_full += f.measurements;
  }
  EXPECT_LT(measured_steered, measured_full);
  // Both parts share one budget: iterations after the first two, and the smallest strength once
  // more when nothing fitted by then.
  CalibrateOptions short_budget = steered;
  short_budget.iterations = 1;
  const Payload first = id_bins(code, 40, key);
  EXPECT_LE(calibrate_strength(prepared, first, eo, short_budget).evaluations, 1 + 3);
  // Nothing fits (an MSDM limit the weakest mark exceeds 4 times over): the smallest strength,
  // which steering embedded, is measured in full without being embedded again.
  CalibrateOptions impossible = steered;
  impossible.max_msdm = 0.02;
  const CalibrateResult none = calibrate_strength(prepared, first, eo, impossible);
  EXPECT_EQ(none.status, CalibrateStatus::BelowMinimum) << none.message;
  EXPECT_EQ(none.measurements, 1);
  EXPECT_EQ(none.evaluations, none.estimates) << "an embedding made twice";
  const std::string small = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(small, "spot.obj");
  const Mesh spot = read_mesh(small);
  const CalibrateResult r = calibrate_strength(spot.V, spot.F, calibration_payload(64, 3), eo);
  EXPECT_EQ(r.estimates, 0) << spot.V.rows() << " vertices";
  EXPECT_GE(r.measurements, 1);
}

// An issuer's copies of one original share MSDM's side of it (CalibrateOptions::
// msdm_reference): the first search that measures MSDM computes it, the later ones walk the
// original's windows no more, and what each search finds is what it finds alone, bit for bit.
// A reference of another mesh is refused.
TEST(Calibrate, ASharedMsdmReferenceIsComputedOnceAndChangesNothing) {
  const std::string path = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh mesh = read_mesh(path);
  EmbedOptions eo;
  const PreparedEmbedder prepared(mesh.V, mesh.F, eo);
  CalibrateOptions shared;
  shared.msdm_reference = std::make_shared<SharedMsdmReference>();
  int original_walks = 0;
  shared.progress = [&](const std::string& phase, long done, long, const std::string&) {
    if (done == 0 && phase.find("the original's windows") != std::string::npos) ++original_walks;
  };
  for (int p = 0; p < 3; ++p) {
    const Payload payload = calibration_payload(64, 20 + p);
    const CalibrateResult alone = calibrate_strength(prepared, payload, eo);
    const CalibrateResult with = calibrate_strength(prepared, payload, eo, shared);
    ASSERT_EQ(alone.status, CalibrateStatus::Calibrated) << alone.message;
    EXPECT_EQ(with.strength, alone.strength) << p;
    EXPECT_EQ(with.msdm, alone.msdm) << p;
    EXPECT_TRUE(with.embedding.V == alone.embedding.V) << p;
  }
  EXPECT_EQ(original_walks, 1) << "the original's windows are walked once for three searches";
  const Mesh other = attack_subdivide(mesh, Subdivision::Loop, 1);
  const PreparedEmbedder other_prepared(other.V, other.F, eo);
  EXPECT_THROW(calibrate_strength(other_prepared, calibration_payload(64, 1), eo, shared),
               InvalidArgumentError);
}

TEST(Calibrate, TheReturnedEmbeddingIsTheMeasuredOne) {
  const std::string path = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh mesh = read_mesh(path);
  EmbedOptions eo;
  eo.variant = parse_variant("VSS");
  const Payload payload = calibration_payload(64, 7);
  const CalibrateResult r = calibrate_strength(mesh.V, mesh.F, payload, eo);
  ASSERT_NE(r.status, CalibrateStatus::BelowMinimum) << r.message;
  EmbedOptions again = eo;
  again.strength = r.strength;
  again.bin_offset = r.bin_offset;
  const EmbedResult w = embed(mesh.V, mesh.F, payload, again);
  EXPECT_TRUE(w.V == r.embedding.V);
  EXPECT_NEAR(vertex_rms_percent(mesh.V, r.embedding.V, mesh.F), r.rms_percent, kSameMeasure);
}

// Each embedding tried is measured with its MSDM's progress named by its strength; reporting
// changes nothing found. The original's windows are walked once, every later measure only the
// copy's: at most one "measuring MSDM" phase per embedding, the last at the strength found.
TEST(Calibrate, ReportsEachMeasuredStrengthAndFindsTheSame) {
  const std::string path = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh mesh = read_mesh(path);
  EmbedOptions eo;
  eo.variant = parse_variant("DRS");
  const Payload payload = calibration_payload(64, 9);
  const CalibrateResult quiet = calibrate_strength(mesh.V, mesh.F, payload, eo);
  ASSERT_EQ(quiet.status, CalibrateStatus::Calibrated) << quiet.message;
  CalibrateOptions o;
  std::vector<std::string> phases;
  long last_done = 0, last_total = -1;
  o.progress = [&](const std::string& phase, long done, long total, const std::string&) {
    if (done == 0) phases.push_back(phase);
    last_done = done, last_total = total;
  };
  const CalibrateResult r = calibrate_strength(mesh.V, mesh.F, payload, eo, o);
  EXPECT_EQ(r.strength, quiet.strength);
  EXPECT_EQ(r.msdm, quiet.msdm);
  EXPECT_TRUE(r.embedding.V == quiet.embedding.V);
  EXPECT_EQ(last_done, last_total);
  EXPECT_EQ(last_total, mesh.V.rows());
  ASSERT_GE(phases.size(), 2u);
  EXPECT_NE(phases.front().find("measuring MSDM (the original's windows)"), std::string::npos);
  int measures = 0;
  for (std::size_t k = 1; k < phases.size(); ++k) {
    EXPECT_EQ(phases[k].rfind("strength ", 0), 0u) << phases[k];
    EXPECT_NE(phases[k].find(": measuring MSDM"), std::string::npos) << phases[k];
    EXPECT_EQ(phases[k].find("original"), std::string::npos) << "walked again: " << phases[k];
    ++measures;
  }
  EXPECT_LE(measures, r.evaluations);
  // The strength found was measured: some phase names it, as printed there (5 decimals).
  const std::string found = fmt::format("strength {:.5f}:", r.strength);
  EXPECT_TRUE(std::any_of(phases.begin(), phases.end(), [&](const std::string& p) {
    return p.rfind(found, 0) == 0;
  })) << found;
}

TEST(Calibrate, FixedRuleKeepsThePapersBinOffset) {
  const std::string path = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh mesh = read_mesh(path);
  EmbedOptions eo;
  eo.bin_offset = 0.05;
  CalibrateOptions o;
  o.bin_offset = BinOffsetRule::Fixed;
  const Payload payload = calibration_payload(64, 3);
  const CalibrateResult fixed = calibrate_strength(mesh.V, mesh.F, payload, eo, o);
  ASSERT_EQ(fixed.status, CalibrateStatus::Calibrated) << fixed.message;
  EXPECT_EQ(fixed.bin_offset, 0.05);
  o.bin_offset = BinOffsetRule::AtMostStrength;
  const CalibrateResult joint = calibrate_strength(mesh.V, mesh.F, payload, eo, o);
  ASSERT_EQ(joint.status, CalibrateStatus::Calibrated) << joint.message;
  // A narrower guard band costs less, so the strongest mark within the same limits is at
  // least as strong (to the search's precision, on both sides).
  if (fixed.strength < 0.05)
    EXPECT_GE(joint.strength * (1 + o.precision) * (1 + o.precision), fixed.strength);
}

TEST(Calibrate, NamesTheLimitThatTheWeakestMarkBreaks) {
  const std::string path = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh mesh = read_mesh(path);
  EmbedOptions eo;
  const Payload payload = calibration_payload(64, 5);
  CalibrateOptions o;
  o.max_rms_percent = 1e-7;  // far below what any mark costs
  CalibrateResult r = calibrate_strength(mesh.V, mesh.F, payload, eo, o);
  ASSERT_EQ(r.status, CalibrateStatus::BelowMinimum);
  EXPECT_EQ(r.cause, CalibrateCause::RmsLimit);
  EXPECT_EQ(r.strength, 0);
  // The figure reported is the weakest mark's, measured again here.
  const EmbedOptions weakest = [&] {
    EmbedOptions e = eo;
    e.strength = o.min_strength;
    e.bin_offset = std::min(eo.bin_offset, o.min_strength);
    return e;
  }();
  const EmbedResult w = embed(mesh.V, mesh.F, payload, weakest);
  ASSERT_EQ(w.status, EmbedStatus::Embedded);
  EXPECT_NEAR(r.rms_percent, vertex_rms_percent(mesh.V, w.V, mesh.F), kSameMeasure);
  ASSERT_FALSE(r.diagnostics.empty());
  EXPECT_NE(r.diagnostics[0].find("RMS"), std::string::npos) << r.diagnostics[0];

  o = {};
  o.max_msdm = 1e-6;
  r = calibrate_strength(mesh.V, mesh.F, payload, eo, o);
  ASSERT_EQ(r.status, CalibrateStatus::BelowMinimum);
  EXPECT_EQ(r.cause, CalibrateCause::MsdmLimit);
  EXPECT_NEAR(r.msdm, msdm(mesh.V, w.V, mesh.F).global, kSameMeasure);
  EXPECT_GT(r.msdm, o.max_msdm);
}

TEST(Calibrate, ACarrierTooSmallForThePayloadIsNamedWithFewerBitsThatFit) {
  // CGAL's cross: 40 vertices, fewer than the 66 bins of 64 bits.
  const std::string path = test::cgal_mesh("cross.off");
  MESHMARK_REQUIRE(path, "cross.off");
  const Mesh mesh = read_mesh(path);
  const CalibrateResult r = calibrate_strength(mesh.V, mesh.F, calibration_payload(64, 1), {});
  ASSERT_EQ(r.status, CalibrateStatus::BelowMinimum);
  EXPECT_EQ(r.cause, CalibrateCause::Carrier);
  EXPECT_EQ(r.evaluations, 1) << "nothing to search when the carrier cannot hold the bits";
  bool fewer = false;
  for (const std::string& line : r.diagnostics)
    fewer |= line.find("bits give every bin enough positions") != std::string::npos;
  EXPECT_TRUE(fewer) << r.message;
  // The number suggested is right: that many bits pass the carrier check, one more does not
  // (or the suggestion is the largest that does).
  for (const std::string& line : r.diagnostics) {
    const auto at = line.find(" bits give every bin enough positions");
    if (at == std::string::npos) continue;
    const int k = std::stoi(line.substr(line.rfind(' ', at - 1) + 1));
    EXPECT_EQ(check_carrier(mesh.V, mesh.F, k).status, CarrierHealth::Healthy) << k;
  }
}

TEST(Calibrate, EmptyBinsAreNamedAsTheCarriersAndFewerBitsSuggested) {
  // featuretype.STL (a CAD part, 2,010 positions): 3 of its 64 bins are empty at 64 bits.
  const std::string path = test::data_mesh("featuretype.STL");
  MESHMARK_REQUIRE(path, "featuretype.STL");
  const Mesh mesh = read_mesh(path);
  const CarrierCheck check = check_carrier(mesh.V, mesh.F, 64);
  ASSERT_GT(check.empty_bins, 0) << "the premise: some bin is empty";
  const CalibrateResult r = calibrate_strength(mesh.V, mesh.F, calibration_payload(64, 2), {});
  ASSERT_EQ(r.status, CalibrateStatus::BelowMinimum);
  EXPECT_EQ(r.cause, CalibrateCause::Carrier);
  EXPECT_NE(r.diagnostics.front().find("bins are empty"), std::string::npos) << r.message;
  bool fewer = false;
  for (const std::string& line : r.diagnostics) {
    const auto at = line.find(" bits give every bin enough positions");
    if (at == std::string::npos) continue;
    fewer = true;
    const int k = std::stoi(line.substr(line.rfind(' ', at - 1) + 1));
    EXPECT_EQ(check_carrier(mesh.V, mesh.F, k).empty_bins, 0) << k;
    // What it says of the limits holds: calibrating that many bits (the same payload's first
    // ones) fits them, or does not, as said.
    Payload prefix = calibration_payload(64, 2);
    prefix.bits.resize(static_cast<std::size_t>(k));
    const CalibrateResult fewer_result = calibrate_strength(mesh.V, mesh.F, prefix, {});
    const bool said_fits = line.find("and fit the limits") != std::string::npos;
    EXPECT_EQ(fewer_result.status != CalibrateStatus::BelowMinimum, said_fits)
        << line << " | " << fewer_result.message;
  }
  EXPECT_TRUE(fewer) << r.message;
}

}  // namespace
}  // namespace meshmark
