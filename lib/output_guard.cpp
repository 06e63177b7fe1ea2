#include "output_guard.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <set>
#include <sstream>
#include <vector>

#include "config.hpp"
#include "error.hpp"
#include "hash.hpp"
#include "mesh.hpp"
#include "results.hpp"
#include "results_commit.hpp"

namespace ltl {

namespace {

namespace fs = std::filesystem;

bool same_file(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
}

/// What is at `path` without following a symbolic link: "" (nothing), "link", "dir", "file",
/// "special".
std::string kind_at(const std::string& path, struct stat* st) {
  if (::lstat(path.c_str(), st) != 0) return "";
  if (S_ISLNK(st->st_mode)) return "link";
  if (S_ISDIR(st->st_mode)) return "dir";
  if (S_ISREG(st->st_mode)) return "file";
  return "special";
}

/// Every value of a TOML tree under its dotted key ("load.traction[0].value[1]").
void flatten(const toml::node& node, const std::string& key,
             std::map<std::string, std::string>& out) {
  if (const toml::table* t = node.as_table()) {
    for (const auto& [k, v] : *t)
      flatten(v, key.empty() ? std::string(k.str()) : cat(key, ".", k.str()), out);
    if (t->empty() && !key.empty()) out[key] = "{}";
  } else if (const toml::array* a = node.as_array()) {
    for (std::size_t i = 0; i < a->size(); ++i) flatten((*a)[i], cat(key, "[", i, "]"), out);
    if (a->empty()) out[key] = "[]";
  } else {
    std::ostringstream s;
    node.visit([&](const auto& v) { s << v; });
    out[key] = s.str();
  }
}

std::string link_target(const std::string& path) {
  std::error_code ec;
  const fs::path t = fs::read_symlink(path, ec);
  return ec ? std::string("?") : t.string();
}

}  // namespace

void check_output_path(const Problem& problem, const std::string& output) {
  if (output.empty()) throw Error("the results file name is empty");
  std::vector<std::pair<std::string, std::string>> inputs = {
      {problem.config_path, "the configuration"}};
  if (!problem.mesh.source.empty()) {
    std::vector<std::string> files{problem.mesh.source};
    try {
      files = scan_geometry(problem.mesh.source).files;
    } catch (const Error&) {
    }
    for (const auto& f : files) inputs.push_back({f, "the geometry"});
  }
  const fs::path out(output);
  for (const std::string& written :
       {output, xdmf_path_of(output), contact_xdmf_path_of(output), output + ".partial",
        journal_path_of(output), lock_path_of(output)})
    for (const auto& [path, what] : inputs)
      if (!path.empty() && same_file(written, path))
        throw Error(cat(output, ": refusing to write the results over ", what, " (", path,
                        written == output ? "" : cat(", via ", written),
                        "); choose another output path"));
  struct stat st {};
  const std::string kind = kind_at(output, &st);
  // A symbolic link at the output path is refused rather than resolved: the rename that commits
  // a change would replace the link, not its target, and writing through it would let whoever
  // made the link choose the file replaced.
  if (kind == "link")
    throw Error(cat(output, ": is a symbolic link (to ", link_target(output),
                    "); refusing to write through it: give the target's path with -o, or remove "
                    "the link"));
  if (kind == "dir")
    throw Error(cat(output, ": is a directory; give a file name for the results (e.g. ",
                    (out / (problem.name + ".h5")).string(), ")"));
  if (kind == "special")
    throw Error(cat(output, ": exists and is not a regular file; refusing to replace it"));
  if (kind == "file") {
    try {
      ResultsFile::read_attribute(output, "config");
    } catch (const Error& e) {
      // An HDF5 file that cannot be opened (a results file cut short?) is named as such.
      const bool damaged = std::string(e.what()).find("damaged") != std::string::npos;
      throw Error(cat(output,
                      damaged ? ": exists and is a damaged or truncated HDF5 file (it has the HDF5 "
                                "signature but cannot be opened)"
                              : ": exists and is not a results file of this code",
                      "; refusing to replace it (remove it or choose another output path)"));
    }
    if ((st.st_mode & S_IWUSR) == 0) {
      char mode[8];
      std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
      throw Error(cat(output, ": is read-only (mode ", mode,
                      "); refusing to replace it (make it writable, chmod u+w, or choose another "
                      "output path)"));
    }
  }
  // The XDMF files beside it are replaced at every commit: only when this code wrote them.
  for (const std::string& xdmf : {xdmf_path_of(output), contact_xdmf_path_of(output)}) {
    const std::string k = kind_at(xdmf, &st);
    if (k.empty() || (k == "file" && is_xdmf_of(xdmf, output))) continue;
    throw Error(cat(output, ": the XDMF file beside it, ", xdmf,
                    k == "link"   ? cat(", is a symbolic link (to ", link_target(xdmf), ")")
                    : k == "file" ? ", was not written by this code for this results file"
                                  : ", is not a regular file",
                    "; refusing to replace it (move it away or choose another output path)"));
  }
}

std::string lock_path_of(const std::string& output) {
  const fs::path out(output);
  const fs::path dir = out.parent_path().empty() ? fs::path(".") : out.parent_path();
  char real[PATH_MAX];
  if (::realpath(dir.c_str(), real) == nullptr) return output + ".lock";
  return (fs::path(real) / (out.filename().string() + ".lock")).string();
}

OutputLock::OutputLock(const std::string& output) : path_(lock_path_of(output)) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC, 0644);
    if (fd_ < 0 && errno == ELOOP)
      throw Error(cat(path_,
                      ": is a symbolic link, not a lock file of this code; refusing to "
                      "follow it (remove it)"));
    if (fd_ < 0) throw Error(cat(path_, ": cannot create the lock file: ", std::strerror(errno)));
    struct stat held {};
    if (::fstat(fd_, &held) != 0 || !S_ISREG(held.st_mode)) {
      ::close(fd_);
      fd_ = -1;
      throw Error(cat(path_, ": is not a regular file, not a lock file of this code (remove it)"));
    }
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      const int e = errno;
      ::close(fd_);
      fd_ = -1;
      if (e == EWOULDBLOCK)
        throw Error(cat(output, ": another process is writing this results file (", path_,
                        " is locked); wait for it to finish"));
      throw Error(cat(path_, ": cannot lock: ", std::strerror(e)));
    }
    struct stat now {};
    if (::lstat(path_.c_str(), &now) == 0 && held.st_dev == now.st_dev && held.st_ino == now.st_ino)
      return;      // the file we locked is the one at the path
    ::close(fd_);  // removed by the previous holder meanwhile: try again
    fd_ = -1;
  }
  throw Error(cat(path_, ": cannot acquire the lock"));
}

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  ::unlink(path_.c_str());
  ::close(fd_);
}

std::map<std::string, std::string> identity(const Problem& problem) {
  return {{"mesh_nodes", std::to_string(problem.mesh.num_nodes())},
          {"mesh_cells", std::to_string(problem.mesh.num_cells())},
          {"mesh_hash", problem.mesh.fingerprint()},
          {"geometry_hash", problem.mesh.source_hash},
          {"config_hash", fingerprint(problem.config_identity)}};
}

std::vector<std::string> configuration_changes(const std::string& stored, const std::string& now) {
  std::map<std::string, std::string> a, b;
  try {
    flatten(toml::parse(stored), "", a);
  } catch (const toml::parse_error&) {
    return {"(the configuration stored in the file cannot be read)"};
  }
  flatten(toml::parse(now), "", b);
  std::vector<std::string> out;
  for (const auto& [key, value] : a) {
    const auto it = b.find(key);
    if (it == b.end() || it->second != value)
      out.push_back(cat(key, " (", value, " in the file, ",
                        it == b.end() ? std::string("not given") : it->second, " now)"));
  }
  for (const auto& [key, value] : b)
    if (!a.count(key)) out.push_back(cat(key, " (not given in the file, ", value, " now)"));
  return out;
}

namespace {

/// Whether two flattened values are the same: equal texts, or numbers within a few rounding
/// errors (a value converted from other units: "4 mm" and "0.4 cm").
bool same_value(const std::string& a, const std::string& b) {
  if (a == b) return true;
  char *ea = nullptr, *eb = nullptr;
  const double x = std::strtod(a.c_str(), &ea), y = std::strtod(b.c_str(), &eb);
  if (ea == a.c_str() || eb == b.c_str() || *ea != '\0' || *eb != '\0') return false;
  return std::abs(x - y) <= 1e-14 * std::max(std::abs(x), std::abs(y));
}

}  // namespace

std::vector<std::string> resolved_changes(const std::string& stored_resolved,
                                          const std::string& now_resolved,
                                          const std::string& stored, const std::string& now) {
  std::map<std::string, std::string> ra, rb, a, b;
  try {
    flatten(toml::parse(stored_resolved), "", ra);
    flatten(toml::parse(stored), "", a);
  } catch (const toml::parse_error&) {
    return {"(the configuration stored in the file cannot be read)"};
  }
  flatten(toml::parse(now_resolved), "", rb);
  flatten(toml::parse(now), "", b);
  // A value is shown as given (with its unit) where it was given, else as resolved.
  const auto shown = [](const std::map<std::string, std::string>& given,
                        const std::map<std::string, std::string>& resolved, const std::string& k) {
    const auto g = given.find(k);
    if (g != given.end()) return g->second;
    const auto r = resolved.find(k);
    return r == resolved.end() ? std::string("not given") : cat(r->second, " (default)");
  };
  std::set<std::string> keys;
  for (const auto& [k, v] : ra) keys.insert(k);
  for (const auto& [k, v] : rb) keys.insert(k);
  std::vector<std::string> out;
  for (const std::string& k : keys) {
    // The geometry is compared by its content and mesh (identity()), not by its path.
    if (k == "mesh.geometry") continue;
    const auto x = ra.find(k), y = rb.find(k);
    if (x != ra.end() && y != rb.end() && same_value(x->second, y->second)) continue;
    out.push_back(cat(k, " (", shown(a, ra, k), " in the file, ", shown(b, rb, k), " now)"));
  }
  return out;
}

bool may_change_on_resume(const std::string& change) {
  return change.rfind("time.steps ", 0) == 0 || change.rfind("algorithm.", 0) == 0 ||
         change.rfind("output.", 0) == 0;
}

ResumePoint resume_point(const Problem& problem, const std::string& out,
                         const std::map<std::string, std::string>& ids, const State& initial) {
  // The file must have been written by this problem: same physics (time.steps may grow, the
  // [algorithm] and [output] keys may change), same geometry file(s), same mesh.
  ResumePoint r{initial, 1, {}};
  for (const auto& [key, value] : ids) {
    const std::string stored = ResultsFile::read_attribute(out, key);
    if (key == "config_hash" || stored == value || stored.empty()) continue;
    throw Error(cat(out, ": cannot resume: ",
                    key == "geometry_hash" ? cat("the geometry file ", problem.mesh.source,
                                                 " changed since the file was written")
                                           : cat("the mesh differs from the file's (", key, " ",
                                                 stored, " in the file, ", value, " now)")));
  }
  const auto hash = ids.find("config_hash");
  if (hash == ids.end() || ResultsFile::read_attribute(out, "config_hash") != hash->second) {
    std::string physics;
    int shown = 0, more = 0;
    // Compared resolved (SI values, defaults filled in) when the file has the resolved
    // configuration: '200 kPa' and 0.2 MPa, or a default given explicitly, are no change.
    const std::string stored = ResultsFile::read_attribute(out, "config");
    const std::string resolved = ResultsFile::read_attribute(out, "config_resolved");
    for (const std::string& change :
         resolved.empty() ? configuration_changes(stored, problem.config_text)
                          : resolved_changes(resolved, resolved_configuration(problem), stored,
                                             problem.config_text)) {
      if (may_change_on_resume(change))
        r.changes.push_back(change);
      else if (shown < 6)
        physics += cat(shown++ ? "; " : "", change);
      else
        ++more;
    }
    if (!physics.empty())
      throw Error(cat(out,
                      ": cannot resume: the configuration differs from the one the file was "
                      "written with in ",
                      physics, more ? cat("; and ", more, " more key(s)") : "",
                      ". Only time.steps and the [algorithm] and [output] keys may change"));
  }
  if (auto last = ResultsFile::read_last_step(out)) {
    const State& s = last->state;
    const State& state = initial;
    if (!same_shapes(s, state))
      throw Error(cat(out, ": cannot resume: step ", last->p,
                      " has the fields of another mesh or contact surface (u is ", s.u.rows(),
                      " x ", s.u.cols(), ", this problem's ", state.u.rows(), " x ", state.u.cols(),
                      ")"));
    if (last->p > problem.time.steps)
      throw Error(cat(out, ": cannot resume: the file already holds step ", last->p,
                      ", beyond time.steps = ", problem.time.steps));
    r.state = s;
    r.next_step = last->p + 1;
  }
  return r;
}

}  // namespace ltl
