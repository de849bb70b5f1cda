#include <gtest/gtest.h>

#include "meshmark/core/error.h"
#include "meshmark/mark/payload.h"

using namespace meshmark;

TEST(Payload, HexReadsLeftToRightInBinOrder) {
  // With 8 bits, "80" is bit 0 (bin 1) alone and "01" is bit 7 (bin 8) alone.
  EXPECT_EQ(payload_from_hex("80", 8).bits, (std::vector<std::uint8_t>{1, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(payload_from_hex("01", 8).bits, (std::vector<std::uint8_t>{0, 0, 0, 0, 0, 0, 0, 1}));
  // 6 bits "2A" = 101010b: bits in order 1 0 1 0 1 0.
  EXPECT_EQ(payload_from_hex("0x2A", 6).bits, (std::vector<std::uint8_t>{1, 0, 1, 0, 1, 0}));
}

TEST(Payload, HexRoundTripsForEveryLength) {
  for (int nb : {1, 3, 4, 7, 32, 63, 64, 65, 200}) {
    const Payload p = random_payload(nb, 1000 + nb);
    EXPECT_EQ(payload_from_hex(payload_to_hex(p), nb), p) << nb;
    EXPECT_EQ(payload_to_hex(p).size(), static_cast<std::size_t>((nb + 3) / 4));
  }
}

TEST(Payload, RejectsBadHexAndOverflow) {
  EXPECT_THROW(payload_from_hex("12g4", 16), InvalidArgumentError);
  EXPECT_THROW(payload_from_hex("", 16), InvalidArgumentError);
  EXPECT_THROW(payload_from_hex("1ff", 8), InvalidArgumentError);  // 9 bits
  EXPECT_THROW(payload_from_hex("1", 0), InvalidArgumentError);
  EXPECT_NO_THROW(payload_from_hex("00ff", 8));  // leading zeros are fine
}

TEST(Payload, RandomIsSeededAndBalanced) {
  EXPECT_EQ(random_payload(64, 7), random_payload(64, 7));
  EXPECT_NE(random_payload(64, 7), random_payload(64, 8));
  int ones = 0;
  for (int s = 0; s < 100; ++s)
    for (auto b : random_payload(64, s).bits) ones += b;
  // 6400 fair bits: mean 3200, sd 40; 5 sd either way.
  EXPECT_NEAR(ones, 3200, 200);
}

TEST(Payload, BitErrorRateCountsErasuresAsErrors) {
  const Payload p = payload_from_hex("f0", 8);
  EXPECT_DOUBLE_EQ(bit_error_rate({1, 1, 1, 1, 0, 0, 0, 0}, p), 0.0);
  EXPECT_DOUBLE_EQ(bit_error_rate({1, 1, 1, 0, 0, 0, 0, 1}, p), 0.25);
  EXPECT_DOUBLE_EQ(bit_error_rate({2, 1, 1, 1, 0, 0, 0, 0}, p), 0.125);
  EXPECT_THROW(bit_error_rate({1}, p), InvalidArgumentError);
}
