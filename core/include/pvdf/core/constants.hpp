// Mathematical constants shared by every module (C++17: std::numbers is C++20).
#pragma once

namespace pvdf {

/// π to double precision (the value of C++20 std::numbers::pi).
inline constexpr double pi = 3.141592653589793238462643383279502884;

}  // namespace pvdf
