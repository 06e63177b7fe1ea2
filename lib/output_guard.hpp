// The guard of a run's results file (the lock, the path checks and the fingerprints, in their own
// file; symbolic links, the files beside the results, permissions):
//  - check_output_path: never over an input of the run, a directory, a special file, a symbolic
//    link, a read-only results file, a file that is not a results file of this code, or an XDMF
//    file beside it that this code did not write;
//  - OutputLock: one writer per results file, keyed on the file (the real directory + name), so
//    that a symlinked alias of the output folder takes the same lock;
//  - identity / resume_point: the fingerprints a results file must match to be resumed.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "problem.hpp"
#include "state.hpp"

namespace ltl {

/// Refuses (Error, naming the file and what to do) an output path that would destroy something:
/// an input of the run (configuration, geometry and the files it includes), a directory, a
/// symbolic link or a special file at the path, an existing file that is not a results file of
/// this code or that is read-only (no owner write permission), and an XDMF file beside it
/// (xdmf_path_of, contact_xdmf_path_of) that this code did not write. The XDMF, working and lock
/// files are checked against the inputs as well.
void check_output_path(const Problem& problem, const std::string& output);

/// The lock file of a results file: `<real directory of output>/<name>.lock`, the directory
/// resolved through symbolic links, so that every path naming the same file names one lock.
std::string lock_path_of(const std::string& output);

/// An exclusive flock on lock_path_of(output), held while the object lives: a second writer
/// (fresh or --resume) is refused while the first runs. The lock file is opened with O_NOFOLLOW
/// (a symbolic link there is refused) and removed on release; the inode check after flock() makes
/// that safe against a writer that opened the file just before.
class OutputLock {
 public:
  explicit OutputLock(const std::string& output);
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  ~OutputLock();

 private:
  std::string path_;
  int fd_ = -1;
};

/// What a results file must match to be resumed: root attribute -> this run's value (node and
/// cell counts, a hash of the coordinates and connectivity, the geometry and configuration
/// hashes).
std::map<std::string, std::string> identity(const Problem& problem);

/// Where a resumed run starts: the state of the file's last step and the next step to compute.
struct ResumePoint {
  State state;
  int next_step = 1;
  /// The keys that changed and may (time.steps, [algorithm], [output]): "algorithm.R (3 in the
  /// file, 4 now)".
  std::vector<std::string> changes;
};

/// The keys whose values differ between two configuration texts (TOML), each as
/// "key (value in the file, value now)"; "not given" for a key on one side only.
std::vector<std::string> configuration_changes(const std::string& stored, const std::string& now);

/// The keys whose values differ between two resolved configurations (resolved_configuration,
/// config.hpp: values in SI, defaults filled in; numbers equal within rounding are the same),
/// `mesh.geometry` left out (the geometry is compared by content); each shown as given in the
/// configuration texts `stored` and `now` where it was given ("'200 kPa' in the file"), else
/// as resolved ("1.0 (default)").
std::vector<std::string> resolved_changes(const std::string& stored_resolved,
                                          const std::string& now_resolved,
                                          const std::string& stored, const std::string& now);

/// Checks that `output` was written by this problem (the mesh and geometry fingerprints `ids`;
/// the configuration key by key, where only time.steps, [algorithm] and [output] may change: the
/// refusal names the other keys that differ, with both values) and that its last
/// step has the fields of `initial`'s shapes, within time.steps. Returns the last step's state
/// (or `initial` and step 1 when the file has no step). Throws Error naming what differs.
ResumePoint resume_point(const Problem& problem, const std::string& output,
                         const std::map<std::string, std::string>& ids, const State& initial);

}  // namespace ltl
