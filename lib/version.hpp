#pragma once

namespace ltl {
/// The package version (CMake's project version).
const char* code_version();
/// `git describe --always --dirty --tags` at configure time ("unknown" outside a git tree).
const char* git_version();
}  // namespace ltl
