// The cost of a key to whoever guesses passphrases against a published fingerprint: one
// derivation and one fingerprint per guess, for the Argon2id derivation of key_from_passphrase
// and the single BLAKE2b of key_from_passphrase_v1 it replaced. One guess per iteration.

#include <benchmark/benchmark.h>

#include <string>

#include "meshmark/forensics/registry.h"
#include "meshmark/protocol/key.h"

using namespace meshmark;

namespace {

template <Key (*derive)(std::string_view)>
void guess_passphrase(benchmark::State& state) {
  std::uint64_t n = 0;
  for (auto _ : state) {
    const std::string fingerprint = key_fingerprint(derive("guess " + std::to_string(n++)));
    benchmark::DoNotOptimize(fingerprint);
  }
}

}  // namespace

BENCHMARK(guess_passphrase<key_from_passphrase>)
    ->Name("PassphraseGuess/argon2id")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(guess_passphrase<key_from_passphrase_v1>)
    ->Name("PassphraseGuess/blake2b")
    ->Unit(benchmark::kMicrosecond);
