// Shared by the shims: cxx turns a std::exception thrown from a function
// declared as returning Result into a Rust Err; any other exception type would
// call std::terminate. Every entry point runs its body through `guard`, so no
// exception of any type crosses the boundary.
#pragma once
#include <stdexcept>
#include <string>

namespace cirrus {

template <typename F> auto guard(const char *library, F &&body) -> decltype(body()) {
  try {
    return body();
  } catch (const std::exception &) {
    throw;
  } catch (...) {
    throw std::runtime_error(std::string("unknown C++ exception in ") + library);
  }
}

} // namespace cirrus
