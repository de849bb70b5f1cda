// Campaign statistics: the median bit error rate per protocol, variant, attack and strength.

#include <fmt/format.h>

#include <algorithm>
#include <map>

#include "meshmark/campaign/campaign.h"

namespace meshmark {

std::vector<SummaryRow> summarize(const CampaignConfig& c, const std::vector<TrialRow>& rows) {
  // Only trials that measured a mark: one without a mark within the limits (no strength met
  // them, the embedding failed) or whose attack failed says nothing of the mark's robustness.
  std::map<std::string, std::vector<double>> groups;
  std::map<std::string, int> excluded;
  for (const TrialRow& r : rows) {
    const std::string key =
        fmt::format("{}|{}|{}|{}", r.protocol, r.variant, r.attack, r.attack_strength);
    if (r.status == "ok")
      groups[key].push_back(r.ber);
    else
      ++excluded[key];
  }
  std::vector<SummaryRow> out;
  for (const CampaignProtocol& p : c.protocols)
    for (const std::string& v : c.variants)
      for (const AttackSeries& s : c.attacks)
        for (const double x : s.strengths) {
          const std::string key = fmt::format("{}|{}|{}|{}", p.name, v, series_label(s), x);
          auto it = groups.find(key);
          if (it == groups.end()) continue;
          std::vector<double> b = it->second;
          std::sort(b.begin(), b.end());
          SummaryRow row;
          row.protocol = p.name;
          row.variant = v;
          row.attack = series_label(s);
          row.attack_strength = x;
          row.trials = static_cast<int>(b.size());
          row.excluded = excluded.count(key) ? excluded[key] : 0;
          const std::size_t n = b.size();
          row.median_ber = n % 2 ? b[n / 2] : 0.5 * (b[n / 2 - 1] + b[n / 2]);
          double sum = 0;
          for (const double e : b) sum += e;
          row.mean_ber = sum / n;
          out.push_back(row);
        }
  return out;
}

}  // namespace meshmark
