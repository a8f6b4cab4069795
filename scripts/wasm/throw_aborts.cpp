// The two C++ ABI entry points a `throw` needs, for wasm32-wasi with clang 14: WebAssembly
// exception handling is not in clang 14's wasi toolchain, so Debian's libc++abi for wasm32 has
// no __cxa_throw. Code compiled for that target keeps its try/catch (the catch blocks are simply
// never entered) and a throw ends the program with the exception's type name instead of
// unwinding. lockroll throws only on bad input (scene files, flags), which a golden run or the
// browser page never gives it.
#include <cstdio>
#include <cstdlib>
#include <typeinfo>

extern "C" void* __cxa_allocate_exception(std::size_t size) noexcept { return std::malloc(size); }

extern "C" [[noreturn]] void __cxa_throw(void*, std::type_info* type, void (*)(void*)) {
    std::fprintf(stderr, "fatal: exception of type %s thrown (no exception support on wasm32-wasi)\n",
                 type ? type->name() : "?");
    std::abort();
}
