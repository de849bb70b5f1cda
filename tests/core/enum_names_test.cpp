// The enum name tables (enum_names.h): every value named once, names parse back in any case,
// unknown names are refused with the list, and the names users type are the documented ones.

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <set>
#include <string>
#include <vector>

#include "meshmark/attacks/attack.h"
#include "meshmark/campaign/campaign.h"
#include "meshmark/carrier/carrier_check.h"
#include "meshmark/carrier/method.h"
#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"
#include "meshmark/forensics/issue.h"
#include "meshmark/forensics/trace.h"
#include "meshmark/mark/calibrate.h"
#include "meshmark/mark/cho.h"
#include "meshmark/mark/embed.h"
#include "meshmark/protocol/coding.h"
#include "meshmark/protocol/detect.h"
#include "meshmark/solve/separable_qp.h"
#include "meshmark/solve/solver_settings.h"
#include "solve/admm_qp.h"

namespace meshmark {
namespace {

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return s;
}

// Every value of E named, distinct names, each parsing back exactly and in upper case, the
// value one past the last named "?", and an unknown name refused with every name listed.
template <class E>
void check_table(std::size_t expected_values) {
  SCOPED_TRACE(EnumTable<E>::what);
  const std::vector<std::string_view> names = enum_names<E>();
  EXPECT_EQ(names.size(), expected_values);
  std::set<std::string> distinct;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const E value = static_cast<E>(i);
    const std::string name(enum_name(value));
    EXPECT_EQ(name, names[i]);
    EXPECT_FALSE(name.empty());
    EXPECT_TRUE(distinct.insert(upper(name)).second) << name << " twice (ignoring case)";
    EXPECT_EQ(parse_enum<E>(name), value);
    EXPECT_EQ(parse_enum<E>(upper(name)), value);
  }
  EXPECT_STREQ(enum_name(static_cast<E>(names.size())), "?");
  try {
    (void)parse_enum<E>("no-such-name");
    ADD_FAILURE() << "an unknown name parsed";
  } catch (const InvalidArgumentError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("no-such-name"), std::string::npos) << message;
    EXPECT_NE(message.find(EnumTable<E>::what), std::string::npos) << message;
    for (const std::string_view name : names)
      EXPECT_NE(message.find(std::string(name)), std::string::npos) << message;
  }
}

// The counts are the enumerators each header declares, counted by hand.
TEST(EnumNames, EveryTableNamesEveryValueOnceAndParsesBack) {
  check_table<AdmmStop>(6);
  check_table<QuantizeConvention>(2);
  check_table<SmoothWeighting>(2);
  check_table<CollusionKind>(2);
  check_table<BinOffsetRule>(2);
  check_table<CalibrateStatus>(3);
  check_table<CalibrateCause>(6);
  check_table<TraceOutcome>(3);
  check_table<CarrierHealth>(3);
  check_table<ChoSearchStatus>(4);
  check_table<IdDecodeStatus>(4);
  check_table<NullModel>(3);
  check_table<EmbedStatus>(4);
  check_table<CopyStatus>(9);
  check_table<FileFormat>(8);
  check_table<Encoding>(3);
  check_table<Method>(3);
  check_table<QpStatus>(3);
  check_table<TraceStatus>(4);
  check_table<SolverBackend>(2);
  check_table<AdmmXStep>(2);
  check_table<RowAuth>(4);
}

// The names users type, as the README and the file formats give them.
TEST(EnumNames, TheTypedNamesAreTheDocumentedOnes) {
  using V = std::vector<std::string_view>;
  EXPECT_EQ(enum_names<Method>(), (V{"qp", "cho-mean", "cho-variance"}));
  EXPECT_EQ(enum_names<SolverBackend>(), (V{"native", "ipopt"}));
  EXPECT_EQ(enum_names<AdmmXStep>(), (V{"cg", "cholesky"}));
  EXPECT_EQ(enum_names<BinOffsetRule>(), (V{"fixed", "at-most-strength"}));
  EXPECT_EQ(enum_names<SmoothWeighting>(), (V{"uniform", "inverse-distance"}));
  EXPECT_EQ(enum_names<QuantizeConvention>(), (V{"levels", "benchmark"}));
  EXPECT_EQ(enum_names<CollusionKind>(), (V{"average", "splice"}));
  // PLY's format line keywords (Turk's PLY specification).
  EXPECT_EQ(enum_names<Encoding>(), (V{"ascii", "binary_little_endian", "binary_big_endian"}));
  // Each format's name is its file extension.
  for (const std::string_view name : enum_names<FileFormat>())
    EXPECT_EQ(format_name(format_from_path("Some.Model." + upper(std::string(name)))), name);
  EXPECT_THROW(format_from_path("model.fbx"), InvalidArgumentError);
  EXPECT_THROW(format_from_path("model"), InvalidArgumentError);
}

}  // namespace
}  // namespace meshmark
