// The shop's job: a key, 100 copies of ORIGINAL for 100 buyers, a leak traced with its report.
#include <meshmark/meshmark.h>
#include <iostream>
int main(int argc, char** argv) try {
  using namespace meshmark;
  if (argc < 2) return std::cerr << "usage: shop ORIGINAL (in an empty folder)\n", 1;
  const IssueSettings shop{.key = generate_key_file("shop.key"), .registry = "shop.db"};
  std::vector<CopyRequest> copies;
  for (std::uint64_t n = 1; n <= 100; ++n)
    copies.push_back({.input = argv[1], .output = "copy-" + std::to_string(n) + ".ply", .buyer = "buyer-" + std::to_string(n), .auto_id = true});
  std::cout << issue_copies(copies, shop).count(CopyStatus::Written) << " copies issued\n";
  write_mesh("leak.ply", apply_attack_chain(read_mesh("copy-42.ply"), parse_attack_chain("similarity:2,simplify:0.5"), 7));
  const TraceFilesRequest leak{.leaked = "leak.ply", .original = argv[1], .registry = "shop.db", .report = "report.html"};
  std::cout << trace_files(leak, *shop.key).trace.message << "\nevidence report: report.html\n";
} catch (const std::exception& e) { return std::cerr << "shop: " << e.what() << "\n", 2; }
