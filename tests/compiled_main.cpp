// doctest's main for glovepose_compiled_tests: a run whose GLOVEPOSE_ISA names a set this CPU does not
// execute is skipped (CTest's SKIP_RETURN_CODE 77), not failed.
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include <glovepose/nn/isa.hpp>

#include <cstdio>
#include <cstdlib>

int main(int argc, char** argv) {
  if (const char* asked = std::getenv("GLOVEPOSE_ISA"); asked != nullptr && *asked != '\0') {
    const auto isa = glovepose::nn::isa_of_word(asked);
    if (isa && !glovepose::nn::cpu_supports(*isa)) {
      std::printf("GLOVEPOSE_ISA=%s: this CPU does not execute it, skipped\n", asked);
      return 77;
    }
  }
  return doctest::Context(argc, argv).run();
}
