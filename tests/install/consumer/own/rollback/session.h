// The consumer's own rollback/session.h (a game may well have one): it is first on the consumer's include path,
// so an installed lockroll header that reached a header of its own as "rollback/session.h" (or an exported
// <prefix>/include/lockroll include dir) would land here. tests/install builds with it.
#pragma once
#error "the consumer's own rollback/session.h was included: a lockroll header must reach its own as <lockroll/rollback/session.h>"
