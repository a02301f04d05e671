#pragma once
// AMHV_ASAN is defined in builds with AddressSanitizer, whichever compiler made them: GCC says so by
// __SANITIZE_ADDRESS__, clang by __has_feature(address_sanitizer).
#if defined(__SANITIZE_ADDRESS__)
#define AMHV_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define AMHV_ASAN 1
#endif
#endif
