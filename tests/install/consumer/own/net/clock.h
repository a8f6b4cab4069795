// The consumer's own net/clock.h (a game may well have one): it is first on the consumer's include path,
// so an installed lockroll header that reached a header of its own as "net/clock.h" (or an exported
// <prefix>/include/lockroll include dir) would land here. tests/install builds with it.
#pragma once
#error "the consumer's own net/clock.h was included: a lockroll header must reach its own as <lockroll/net/clock.h>"
