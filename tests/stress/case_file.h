#pragma once
// Stress cases as text files: the differential fuzzer saves every disagreement it finds as one,
// and the regression test replays every file of tests/stress/regressions/. Numbers are C99
// hexadecimal floats (printf "%a"), so a case reproduces bit for bit.
//
//   # why this case was saved
//   sphere <cx> <cy> <cz> <r>
//   triangle <ax> <ay> <az> <bx> <by> <bz> <cx> <cy> <cz>
//   mesh <vertex count> <triangle count> [closed]
//   v <x> <y> <z>                    (vertex count lines)
//   f <i> <j> <k>                    (triangle count lines)
//   ray <ox> <oy> <oz> <dx> <dy> <dz> <tmin> <tmax>

#include <string>

#include "tests/stress/harness.h"

namespace raycastd::stress {

/// The case as text (objects in order, then rays).
std::string write_case(const StressCase& c, const std::string& comment);

/// Parses a case file's text; false (with `error` set) on a malformed line.
bool read_case(const std::string& text, StressCase& out, std::string& error);

}  // namespace raycastd::stress
