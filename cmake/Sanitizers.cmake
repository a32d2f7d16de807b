# PVDF_SANITIZE=ON builds everything with AddressSanitizer and UndefinedBehaviorSanitizer (any
# error aborts the test that hit it). Meant for the modules without deal.II:
#   cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DPVDF_SANITIZE=ON -DPVDF_WITH_FEM=OFF \
#     -DPVDF_BUILD_BENCH=OFF -DPVDF_BUILD_PYTHON=OFF
#   cmake --build build-asan -j2 && ctest --test-dir build-asan
# (scripts/run-sanitized-tests does this, and excludes the tests that cannot run instrumented;
# Debug keeps PVDF_ASSERT and _GLIBCXX_ASSERTIONS on). deal.II itself is not instrumented, so the
# finite-element modules are left out rather than reported with false positives.
option(PVDF_SANITIZE "Build with AddressSanitizer and UBSan (use with PVDF_WITH_FEM=OFF)" OFF)
if(PVDF_SANITIZE)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    message(FATAL_ERROR "PVDF_SANITIZE needs GCC or Clang")
  endif()
  set(PVDF_SANITIZER_FLAGS -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
  add_compile_options(${PVDF_SANITIZER_FLAGS} -O1 -g)
  add_link_options(-fsanitize=address,undefined)
  # Leaks of third-party singletons at exit (Gmsh, HDF5) are not ours; memory errors are.
  set(PVDF_SANITIZER_ENV "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1;UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1")
endif()
