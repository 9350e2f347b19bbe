// Internal invariants (docs/architecture.md, "Errors say what, where and what to do"). A broken
// invariant is a bug in vkmech, never bad input: VKM_ASSERT(condition, message) throws
// InternalError naming the source file, the line and the condition. It is checked in every
// build (a renderer that went on would write a wrong image without a word), so keep it off hot
// loops. Bad input keeps its typed errors (SceneError, UsageError, std::invalid_argument from
// the parse_* functions: exit 2); an InternalError is exit 1 with a request to report it.
#pragma once

#include <stdexcept>
#include <string>

namespace vkmech {

class InternalError : public std::logic_error {
public:
    using std::logic_error::logic_error;
};

// Throws InternalError("<file>:<line>: <condition> failed: <message>"), the file relative to
// the source tree.
[[noreturn]] void fail_invariant(const char* file, int line, const char* condition, const std::string& message);

}  // namespace vkmech

#define VKM_ASSERT(condition, message)                                                         \
    do {                                                                                       \
        if (!(condition)) ::vkmech::fail_invariant(__FILE__, __LINE__, #condition, (message)); \
    } while (false)
