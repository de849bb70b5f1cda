#pragma once
/// \file progress.h
/// How the library reports long work (a batch of copies, a trace, a campaign) to its caller,
/// who decides whether and how to show it (the CLI draws a line on a terminal only).

#include <functional>
#include <string>

namespace meshmark {

/// Called as work is done: the phase (a short lower-case verb phrase, "issuing"), units done
/// and to do in this phase, and what was just done (a file, a copy, or ""). Called with done 0
/// when a phase starts, then with done increasing up to total. Called from any thread, but
/// never from two at once. An empty function reports nothing.
using ProgressCallback =
    std::function<void(const std::string& phase, long done, long total, const std::string& what)>;

}  // namespace meshmark
