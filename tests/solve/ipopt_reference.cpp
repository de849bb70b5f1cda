#include "solve/ipopt_reference.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>

namespace meshmark::test {

GeneralQp drs_reference_problem(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                const std::vector<int>& bits, double alpha, double G,
                                std::vector<int>& referenced, Eigen::MatrixX3d& directions) {
  // One variable per distinct position (its first vertex), as every position counts once.
  std::set<int> used(F.data(), F.data() + F.size());
  std::map<std::array<double, 3>, int> first;
  for (int i : used)
    first.emplace(std::array<double, 3>{V(i, 0) + 0.0, V(i, 1) + 0.0, V(i, 2) + 0.0}, i);
  referenced.clear();
  for (const auto& [p, i] : first) referenced.push_back(i);
  std::sort(referenced.begin(), referenced.end());
  const auto n = static_cast<Eigen::Index>(referenced.size());
  Eigen::Vector3d C = Eigen::Vector3d::Zero();
  for (int i : referenced) C += V.row(i).transpose();
  C /= static_cast<double>(n);
  Eigen::VectorXd rho(n);
  directions.resize(n, 3);
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Vector3d d = V.row(referenced[k]).transpose() - C;
    rho(k) = d.norm();
    directions.row(k) = (d / rho(k)).transpose();
  }
  const double lo = rho.minCoeff(), hi = rho.maxCoeff();
  const int nb = static_cast<int>(bits.size()), nB = nb + 2;
  const double s = (hi - lo) / nB;
  std::vector<int> bin(static_cast<std::size_t>(n));
  Eigen::VectorXd t(n), sum_t = Eigen::VectorXd::Zero(nB), count = Eigen::VectorXd::Zero(nB);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double x = (rho(k) - lo) / s;
    bin[k] = std::min(static_cast<int>(std::floor(x)), nB - 1);
    t(k) = x - bin[k];
    sum_t(bin[k]) += t(k);
    count(bin[k]) += 1;
  }
  GeneralQp qp;
  qp.c = Eigen::VectorXd::Ones(n);
  qp.x_lo.resize(n);
  qp.x_hi.resize(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const bool fixed = rho(k) == lo || rho(k) == hi;
    qp.x_lo(k) = fixed ? 0 : s * (G - t(k));
    qp.x_hi(k) = fixed ? 0 : s * (1 - G - t(k));
  }
  qp.row_lo.resize(nb + 3);
  qp.row_hi.resize(nb + 3);
  for (int j = 0; j < nb; ++j) {
    const double mj = bits[j] ? 1 : -1;
    qp.row_lo(j) = alpha - mj * (sum_t(j + 1) / count(j + 1) - 0.5);
    qp.row_hi(j) = 1e19;  // Ipopt's infinity
  }
  for (int a = 0; a < 3; ++a) qp.row_lo(nb + a) = qp.row_hi(nb + a) = 0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const int b = bin[k];
    if (b >= 1 && b <= nb) qp.A.emplace_back(b - 1, k, (bits[b - 1] ? 1.0 : -1.0) / (count(b) * s));
    for (int a = 0; a < 3; ++a)
      qp.A.emplace_back(nb + a, k, directions(k, a) / static_cast<double>(n));
  }
  return qp;
}

}  // namespace meshmark::test
