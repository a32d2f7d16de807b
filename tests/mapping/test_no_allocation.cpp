// The hot path allocates nothing: operator new is counted in this executable (its own test
// binary, so the counting cannot disturb other tests) while many presses are located.
#include "fixture.hpp"

#include "pvdf/mapping/locator.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <cstdlib>
#include <new>

namespace {
std::atomic<long> allocations{0};
}

void* operator new(std::size_t size) {
  ++allocations;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

TEST_CASE("Locator::locate does not allocate", "[mapping][locator]") {
  using namespace pvdf::mapping;
  SyntheticModel model;
  model.force_skew = 0.05;
  const Locator locator(build_synthetic_map(model, 1e-3, 3e-3, {0.25, 0.5, 1.0, 2.0, 4.0}, 0.05e-12));
  const auto presses = pvdf_test::random_presses(500, 0.03, 0.3, 3.0, 1);
  std::vector<std::array<double, 3>> q(presses.size());
  for (std::size_t i = 0; i < presses.size(); ++i) {
    for (std::size_t k = 0; k < 3; ++k) q[i][k] = model.charge_C(presses[i].x_m, presses[i].y_m, presses[i].force_N, k);
  }
  const std::array<double, 3> none{1e-16, 0.0, -1e-16}, outside{2e-10, 5e-13, 5e-13};
  std::vector<Location> out(presses.size() + 2);
  const long before = allocations.load();
  for (std::size_t i = 0; i < presses.size(); ++i) out[i] = locator.locate(q[i].data());
  out[presses.size()] = locator.locate(none.data());
  out[presses.size() + 1] = locator.locate(outside.data(), 1.0);
  const long after = allocations.load();
  CHECK(before > 0);  // the counter is live (building the map allocated)
  CHECK(after - before == 0);
  CHECK(out[0].has_position());  // the loop really ran
}
