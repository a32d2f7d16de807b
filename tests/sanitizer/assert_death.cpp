// The check of PVDF_ASSERT itself (test assert_macro, assert_death.sh beside it): with assertions
// on, the broken invariant below must print file:line, the condition and the message to stderr and
// abort before main returns; with them off, neither condition may even be evaluated.
#include "pvdf/core/assert.hpp"

#include <cstddef>
#include <cstdio>
#include <string>

int main(int argc, char**) {
  int evaluated = 0;
  const std::size_t n_values = static_cast<std::size_t>(argc) + 2;  // 3 without arguments, unknown to the compiler
  PVDF_ASSERT((++evaluated, n_values == 3), "holds: must not abort");
  PVDF_ASSERT((++evaluated, n_values == 4), "sizes differ: " + std::to_string(n_values) + " values for 4 nodes");
  std::printf("returned; conditions evaluated: %d\n", evaluated);
  return 0;
}
