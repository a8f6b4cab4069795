// Output paths named on the command line (--out, --json, --record) are checked before any work
// starts: a typo or an unwritable place fails at once with a UsageError (exit 2) naming the flag
// and the path, instead of after a long run, and the check leaves nothing behind (it creates
// no directory; its probe file is removed at once).
//
// Contract
//  - check_output_file: the path is not empty, is not a directory or a device (a regular file
//    there is replaced), its directory exists, and a file can be created in that directory
//    (write_file_atomic creates its temporary file there).
//  - check_output_dir: the path is not empty, is a directory or does not exist yet, and a file
//    can be created in it or, when it does not exist, in its nearest existing ancestor (which
//    must be a directory), so that create_directories will succeed later.
//  - Passing is not a promise (the disk may fill meanwhile); writing still reports its own
//    failures (exit 1).
#pragma once

#include <string>

namespace lockroll::harness {

void check_output_file(const std::string& flag, const std::string& path);
void check_output_dir(const std::string& flag, const std::string& path);

}  // namespace lockroll::harness
