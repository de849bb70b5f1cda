// libFuzzer target for campaign files (campaign.h's load_campaign): the input is the JSON file;
// its models are looked up beside it (a scratch folder under /tmp holding nothing) and under
// MESHMARK_DATA_DIR, which scripts/fuzz.sh sets to the checkout's data/ folder. The loader may
// accept the file or throw meshmark::Error; anything else (a crash, a sanitizer report, another
// exception, a hang) is a bug, and so is an accepted campaign that breaks what the loader
// promises (checked below). Built and run by scripts/fuzz.sh.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "campaign/campaign_parts.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/core/error.h"

namespace {

// What load_campaign promises of every campaign it accepts (campaign.h, docs/evaluation.md).
bool keeps_its_promises(const meshmark::CampaignConfig& c) {
  if (c.models.empty() || c.variants.empty() || c.protocols.empty()) return false;
  for (const meshmark::CampaignModel& m : c.models)
    if (m.name.empty() || !std::filesystem::is_regular_file(m.path)) return false;
  if (c.bits < 1 || c.bits > 4096 || c.payloads < 1 || c.draws < 1) return false;
  if (c.attacks.empty() || c.attacks.front().kind != "none") return false;
  if (c.trace && (c.copies < 2 || c.copies > 1000000 || !(c.spread >= 0 && c.spread <= 4)))
    return false;
  if (!c.calibrate && !(c.strength > 0 && c.strength < 0.5)) return false;
  // Every accepted re-marking names itself in a form that parses back to it.
  for (const meshmark::CampaignRemark& r : c.remarks) {
    if (!c.trace || !(r.strength >= 0 && r.strength < 0.5)) return false;
    const meshmark::CampaignRemark back = meshmark::parse_remark(meshmark::remark_name(r));
    if (back.scheme != r.scheme || back.strength != r.strength || back.other_key != r.other_key)
      return false;
  }
  // Innocent leaks only in trace mode, each once, each labelled in reports (the label parses
  // the name back).
  for (std::size_t i = 0; i < c.innocents.size(); ++i) {
    if (!c.trace) return false;
    for (std::size_t k = 0; k < i; ++k)
      if (c.innocents[k] == c.innocents[i]) return false;
    (void)meshmark::trace_attack_label("none", 0, meshmark::innocent_name(c.innocents[i]));
  }
  // Every accepted series runs: each of its strengths makes a chain the attacks take.
  for (std::size_t i = 1; i < c.attacks.size(); ++i) {
    if (c.attacks[i].strengths.empty() || c.attacks[i].draws < 0) return false;
    for (const double x : c.attacks[i].strengths) try {
        (void)meshmark::series_chain(c.attacks[i], x);
      } catch (const meshmark::Error&) {
        return false;
      }
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("meshmark-fuzz-campaign-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "campaign.json").string();
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  try {
    const meshmark::CampaignConfig c = meshmark::load_campaign(path);
    if (!keeps_its_promises(c)) __builtin_trap();
  } catch (const meshmark::Error&) {
    // refused with a typed error: fine
  }
  return 0;
}
