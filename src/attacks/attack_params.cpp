// Parameters of the attacks whose definition varies in the literature: names, labels, checks.

#include <fmt/format.h>

#include <cmath>
#include <vector>

#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"

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

namespace {

// A parameter of AttackParams: its bit, its name, and whether it differs from its default.
struct ParamField {
  AttackParamBits bit;
  const char* name;
  bool (*given)(const AttackParams&);
};

const ParamField kFields[] = {
    {kReadsLambda, "lambda", [](const AttackParams& p) { return p.lambda != 0; }},
    {kReadsMu, "mu", [](const AttackParams& p) { return p.mu != 0; }},
    {kReadsFixedBoundary, "fixed_boundary", [](const AttackParams& p) { return p.fixed_boundary; }},
    {kReadsWeighting, "weighting",
     [](const AttackParams& p) { return p.weighting != SmoothWeighting::Uniform; }},
    {kReadsConvention, "convention",
     [](const AttackParams& p) { return p.convention != QuantizeConvention::Levels; }},
};

// The kind's table entry. \throw InvalidArgumentError for an unknown kind, listing the kinds.
const AttackKind& kind_of(const std::string& kind) {
  return attack_kind(kind);
}

}  // namespace

std::vector<std::string> attack_param_names(unsigned bits) {
  std::vector<std::string> names;
  for (const ParamField& f : kFields)
    if (bits & f.bit) names.emplace_back(f.name);
  return names;
}

void check_attack_params(const std::string& kind, const AttackParams& p) {
  const unsigned reads = kind_of(kind).params;
  for (const ParamField& f : kFields)
    if (f.given(p) && !(reads & f.bit))
      throw InvalidArgumentError(fmt::format("attack '{}' takes no parameter '{}'", kind, f.name));
  // Taubin's (the kind with a mu) shrinks by lambda > 0 and inflates by mu < 0.
  if (!std::isfinite(p.lambda) || ((reads & kReadsMu) && p.lambda < 0))
    throw InvalidArgumentError(
        fmt::format("attack '{}': lambda {} is out of range", kind, p.lambda));
  if (!(p.mu <= 0 && std::isfinite(p.mu)))
    throw InvalidArgumentError(fmt::format("attack '{}': mu {} must be negative", kind, p.mu));
}

void set_chain_params(std::vector<AttackStep>& steps, const AttackParams& p) {
  unsigned read = 0;
  for (AttackStep& s : steps) {
    const unsigned reads = kind_of(s.kind).params;
    read |= reads;
    AttackParams& q = s.params;
    if ((reads & kReadsLambda) && p.lambda != 0) q.lambda = p.lambda;
    if ((reads & kReadsMu) && p.mu != 0) q.mu = p.mu;
    if (reads & kReadsFixedBoundary) q.fixed_boundary = q.fixed_boundary || p.fixed_boundary;
    if ((reads & kReadsWeighting) && p.weighting != SmoothWeighting::Uniform)
      q.weighting = p.weighting;
    if ((reads & kReadsConvention) && p.convention != QuantizeConvention::Levels)
      q.convention = p.convention;
  }
  for (const ParamField& f : kFields)
    if (f.given(p) && !(read & f.bit))
      throw InvalidArgumentError(fmt::format("no step of the attack reads '{}'", f.name));
  for (const AttackStep& s : steps) check_attack_params(s.kind, s.params);
}

const char* smooth_weighting_name(SmoothWeighting w) {
  return enum_name(w);
}

SmoothWeighting parse_smooth_weighting(const std::string& name) {
  return parse_enum<SmoothWeighting>(name);
}

const char* quantize_convention_name(QuantizeConvention c) {
  return enum_name(c);
}

QuantizeConvention parse_quantize_convention(const std::string& name) {
  return parse_enum<QuantizeConvention>(name);
}

}  // namespace meshmark
