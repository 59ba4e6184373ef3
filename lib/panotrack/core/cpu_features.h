#pragma once

// Run-time checks of the processor's vector extensions, for the few loops
// compiled for them beside a portable version (target attributes; the build
// itself targets the baseline x86-64).

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define PANO_HAVE_X86_TARGETS 1
#endif

namespace pano {

#ifdef PANO_HAVE_X86_TARGETS
inline bool HaveAvx2() {
  static const bool have = __builtin_cpu_supports("avx2");
  return have;
}
#endif

}  // namespace pano
