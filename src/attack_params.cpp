// Parameters of the attacks whose definition varies in the literature: names, labels, checks.

#include <fmt/format.h>

#include <cmath>
#include <vector>

#include "meshmark/attack.h"
#include "meshmark/error.h"

namespace meshmark {

bool attack_params_default(const AttackParams& p) {
  return attack_params_label(p).empty();
}

std::string attack_params_label(const AttackParams& p) {
  std::vector<std::string> items;
  if (p.lambda != 0) items.push_back(fmt::format("lambda={:g}", p.lambda));
  if (p.mu != 0) items.push_back(fmt::format("mu={:g}", p.mu));
  if (p.fixed_boundary) items.emplace_back("fixed_boundary");
  if (p.weighting != SmoothWeighting::Uniform)
    items.push_back(fmt::format("weighting={}", smooth_weighting_name(p.weighting)));
  if (p.convention != QuantizeConvention::Levels)
    items.push_back(fmt::format("convention={}", quantize_convention_name(p.convention)));
  return fmt::format("{}", fmt::join(items, " "));
}

void check_attack_params(const std::string& kind, const AttackParams& p) {
  const bool smoothing = kind == "smooth" || kind == "taubin";
  auto refuse = [&](bool given, const char* name) {
    if (given)
      throw InvalidArgumentError(fmt::format("attack '{}' takes no parameter '{}'", kind, name));
  };
  refuse(!smoothing && p.lambda != 0, "lambda");
  refuse(kind != "taubin" && p.mu != 0, "mu");
  refuse(!smoothing && p.fixed_boundary, "fixed_boundary");
  refuse(!smoothing && p.weighting != SmoothWeighting::Uniform, "weighting");
  refuse(kind != "quant" && p.convention != QuantizeConvention::Levels, "convention");
  if (!std::isfinite(p.lambda) || (kind == "taubin" && p.lambda < 0))
    throw InvalidArgumentError(
        fmt::format("attack '{}': lambda {} is out of range", kind, p.lambda));
  if (!(p.mu <= 0 && std::isfinite(p.mu)))
    throw InvalidArgumentError(fmt::format("attack '{}': mu {} must be negative", kind, p.mu));
}

void set_chain_params(std::vector<AttackStep>& steps, const AttackParams& p) {
  bool smoothing = false, taubin = false, quant = false;
  for (AttackStep& s : steps) {
    if (s.kind == "smooth" || s.kind == "taubin") {
      smoothing = true;
      s.params.lambda = p.lambda != 0 ? p.lambda : s.params.lambda;
      s.params.fixed_boundary = s.params.fixed_boundary || p.fixed_boundary;
      if (p.weighting != SmoothWeighting::Uniform) s.params.weighting = p.weighting;
    }
    if (s.kind == "taubin") {
      taubin = true;
      s.params.mu = p.mu != 0 ? p.mu : s.params.mu;
    }
    if (s.kind == "quant") {
      quant = true;
      if (p.convention != QuantizeConvention::Levels) s.params.convention = p.convention;
    }
  }
  auto unread = [&](bool given, bool read, const char* name) {
    if (given && !read)
      throw InvalidArgumentError(fmt::format("no step of the attack reads '{}'", name));
  };
  unread(p.lambda != 0, smoothing, "lambda");
  unread(p.mu != 0, taubin, "mu");
  unread(p.fixed_boundary, smoothing, "fixed_boundary");
  unread(p.weighting != SmoothWeighting::Uniform, smoothing, "weighting");
  unread(p.convention != QuantizeConvention::Levels, quant, "convention");
  for (const AttackStep& s : steps) check_attack_params(s.kind, s.params);
}

const char* smooth_weighting_name(SmoothWeighting w) {
  return w == SmoothWeighting::Uniform ? "uniform" : "inverse-distance";
}

SmoothWeighting parse_smooth_weighting(const std::string& name) {
  if (name == "uniform") return SmoothWeighting::Uniform;
  if (name == "inverse-distance") return SmoothWeighting::InverseDistance;
  throw InvalidArgumentError(
      fmt::format("weighting '{}' is neither 'uniform' nor 'inverse-distance'", name));
}

const char* quantize_convention_name(QuantizeConvention c) {
  return c == QuantizeConvention::Levels ? "levels" : "benchmark";
}

QuantizeConvention parse_quantize_convention(const std::string& name) {
  if (name == "levels") return QuantizeConvention::Levels;
  if (name == "benchmark") return QuantizeConvention::Benchmark;
  throw InvalidArgumentError(
      fmt::format("quantization convention '{}' is neither 'levels' nor 'benchmark'", name));
}

}  // namespace meshmark
