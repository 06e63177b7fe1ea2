// --checkpoint: the iterate of a step in progress saved in the results file (never as a result),
// and --resume continuing the step from it. A run killed or interrupted in the middle of a step
// and resumed must end in the state of the run that was never stopped, in the same total number
// of ALG2 iterations: plain ALG2 (4.1)-(4.3) with the paper's stopping test (4.4) depends on its
// iterate alone, so the continuation is exact.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "error.hpp"
#include "results.hpp"
#include "testing.hpp"

namespace {

namespace fs = std::filesystem;
using ltl::ResultsFile;

/// ltl_run on Fig 5 with plain ALG2 (902 iterations) and `extra` arguments, in `dir`; stderr into
/// `err`. Returns the pid (wait == false) or the exit status (wait == true).
int ltl_run(const fs::path& dir, std::vector<std::string> extra, const fs::path& err, bool wait) {
  std::vector<std::string> args = {ltl::testing::source_path("experiments/fig5/fig5.toml"),
                                   "-q",
                                   "-o",
                                   "out.h5",
                                   "--set",
                                   "algorithm.solver=\"alg2\""};
  args.insert(args.end(), extra.begin(), extra.end());
  const pid_t pid =
      ltl::testing::spawn(ltl::testing::binary_path("experiments/ltl_run"), args, dir, err);
  if (!wait) return pid;
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The run of Fig 5 that is never stopped: its iterations and u.
struct Reference {
  int iterations = 0;
  Eigen::MatrixXd u;
};
const Reference& reference() {
  static const Reference ref = [] {
    const fs::path dir = ltl::testing::temp_dir("checkpoint_ref");
    Reference r;
    if (ltl_run(dir, {}, dir / "err", true) != 0) return r;
    const auto step = ResultsFile::read_last_step((dir / "out.h5").string());
    r.iterations = step->iterations;
    r.u = step->state.u;
    fs::remove_all(dir);
    return r;
  }();
  return ref;
}

/// Starts the run with a checkpoint every millisecond, waits for the first checkpoint of step 1,
/// then sends `sig`: the exit status (128 + signal when ended by one) and the checkpoint left.
/// When the step finished before the signal (a machine too slow to catch it), tries again with
/// the file removed, three times at most; false when every try finished first.
bool stop_in_the_middle(const fs::path& dir, int sig, int& status, ltl::StoredStep& saved,
                        std::vector<std::string> extra = {}) {
  extra.insert(extra.end(), {"--checkpoint", "0.001"});
  const std::string out = (dir / "out.h5").string();
  for (int attempt = 0; attempt < 3; ++attempt) {
    fs::remove(out);
    const pid_t pid = ltl_run(dir, extra, dir / "err", false);
    for (int i = 0; i < 20000; ++i) {
      if (fs::exists(out)) try {
          if (ResultsFile::read_checkpoint(out, 1)) break;
        } catch (const ltl::Error&) {  // created but not yet readable
        }
      ::usleep(500);
    }
    ::kill(pid, sig);
    int st = 0;
    ::waitpid(pid, &st, 0);
    status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    if (!fs::exists(out) || ResultsFile::read_last_step(out)) continue;  // finished first
    if (const auto c = ResultsFile::read_checkpoint(out, 1)) {
      saved = *c;
      return true;
    }
  }
  return false;
}

// A run killed (SIGKILL: no handler runs) in the middle of its step keeps the last checkpoint;
// --resume continues from it and ends in the uninterrupted run's state, its iterations adding up
// to the uninterrupted run's 902.
TEST(Checkpoint, Eq4_4_KilledRunResumesFromItsCheckpointToTheSameStateAndCount) {
  const Reference& ref = reference();
  ASSERT_EQ(ref.iterations, 902);
  const fs::path dir = ltl::testing::temp_dir("checkpoint_kill");
  int status = 0;
  ltl::StoredStep saved;
  ASSERT_TRUE(stop_in_the_middle(dir, SIGKILL, status, saved))
      << "the step always finished before SIGKILL";
  EXPECT_EQ(status, 128 + SIGKILL);
  EXPECT_EQ(saved.p, 1);
  EXPECT_EQ(saved.load_factor, 1.0);
  ASSERT_GT(saved.iterations, 0);
  ASSERT_LT(saved.iterations, ref.iterations);
  const std::string out = (dir / "out.h5").string();
  // The lock of the killed writer is free: a new process takes it.
  ASSERT_EQ(ltl_run(dir, {"--resume"}, dir / "err", true), 0) << read_text(dir / "err");
  const auto step = ResultsFile::read_last_step(out);
  ASSERT_TRUE(step);
  EXPECT_EQ(saved.iterations + step->iterations, ref.iterations)
      << saved.iterations << " before the kill, " << step->iterations << " after";
  EXPECT_LE((step->state.u - ref.u).norm(), 1e-13 * ref.u.norm());
  // The result supersedes the checkpoint; the file says it is complete.
  EXPECT_FALSE(ResultsFile::read_checkpoint(out, 1));
  EXPECT_EQ(ResultsFile::read_attribute(out, "status"), "complete");
  std::printf(
      "killed after the checkpoint of iteration %d, resumed for %d: %d (uninterrupted %d)\n",
      saved.iterations, step->iterations, saved.iterations + step->iterations, ref.iterations);
  fs::remove_all(dir);
}

// SIGTERM (and Ctrl-C) in the middle of a step saves the iterate at that iteration before the
// run stops; the message and the file's status say so and how to continue.
TEST(Checkpoint, Eq4_4_InterruptSavesTheIterateAndSaysHowToContinue) {
  const Reference& ref = reference();
  const fs::path dir = ltl::testing::temp_dir("checkpoint_term");
  int status = 0;
  ltl::StoredStep saved;
  ASSERT_TRUE(stop_in_the_middle(dir, SIGTERM, status, saved))
      << "the step always finished before SIGTERM";
  EXPECT_EQ(status, 128 + SIGTERM);
  const std::string msg = read_text(dir / "err");
  const std::string said = "step 1's iterate after " + std::to_string(saved.iterations) +
                           " iterations is saved (a checkpoint): --resume continues the step";
  EXPECT_NE(msg.find(said), std::string::npos) << msg;
  EXPECT_NE(msg.find("holds no completed step"), std::string::npos) << msg;
  const std::string out = (dir / "out.h5").string();
  EXPECT_NE(ResultsFile::read_attribute(out, "status").find(said), std::string::npos);
  ASSERT_EQ(ltl_run(dir, {"--resume"}, dir / "err", true), 0) << read_text(dir / "err");
  const auto step = ResultsFile::read_last_step(out);
  ASSERT_TRUE(step);
  EXPECT_EQ(saved.iterations + step->iterations, ref.iterations);
  EXPECT_LE((step->state.u - ref.u).norm(), 1e-13 * ref.u.norm());
  fs::remove_all(dir);
}

// A run started with --init (the nested start) and stopped in its step 1 starts that step again
// from the --init file's state (its beta_{p-1}, its retries) and continues from the checkpoint:
// the same total as the uninterrupted nested run. Without the --init file it is refused.
TEST(Checkpoint, Eq4_4_ANestedStartIsContinuedFromItsCheckpoint) {
  const fs::path dir = ltl::testing::temp_dir("checkpoint_nested");
  const std::vector<std::string> coarse = {"--set", "mesh.parameters.n=5", "--set",
                                           "mesh.parameters.nd=5"};
  ASSERT_EQ(ltl_run(dir, coarse, dir / "err", true), 0) << read_text(dir / "err");
  fs::rename(dir / "out.h5", dir / "coarse.h5");
  ASSERT_EQ(ltl_run(dir, {"--init", "coarse.h5"}, dir / "err", true), 0) << read_text(dir / "err");
  const int nested = ResultsFile::read_last_step((dir / "out.h5").string())->iterations;
  int status = 0;
  ltl::StoredStep saved;
  ASSERT_TRUE(stop_in_the_middle(dir, SIGTERM, status, saved, {"--init", "coarse.h5"}))
      << "the step always finished before SIGTERM";
  fs::rename(dir / "coarse.h5", dir / "gone.h5");
  EXPECT_EQ(ltl_run(dir, {"--resume"}, dir / "err", true), 1);
  EXPECT_NE(read_text(dir / "err")
                .find("its step 1 starts from coarse.h5 (--init), which no "
                      "longer exists"),
            std::string::npos)
      << read_text(dir / "err");
  fs::rename(dir / "gone.h5", dir / "coarse.h5");
  ASSERT_EQ(ltl_run(dir, {"--resume"}, dir / "err", true), 0) << read_text(dir / "err");
  const auto step = ResultsFile::read_last_step((dir / "out.h5").string());
  EXPECT_EQ(saved.iterations + step->iterations, nested)
      << saved.iterations << " + " << step->iterations << " against " << nested;
  fs::remove_all(dir);
}

// The iterate of a step that diverged (here: the iteration cap) is kept for diagnosis but is
// not a checkpoint: --resume starts the step again from the last completed state, never from it.
TEST(Checkpoint, Eq4_4_ADivergedIterateIsNeverContinuedFrom) {
  const Reference& ref = reference();
  const fs::path dir = ltl::testing::temp_dir("checkpoint_capped");
  const std::string out = (dir / "out.h5").string();
  EXPECT_EQ(
      ltl_run(dir, {"--checkpoint", "0.001", "--set", "algorithm.max_iter=300"}, dir / "err", true),
      1);
  EXPECT_NE(read_text(dir / "err").find("iteration cap"), std::string::npos)
      << read_text(dir / "err");
  EXPECT_FALSE(ResultsFile::read_checkpoint(out, 1));  // replaced by the diverged iterate
  EXPECT_FALSE(ResultsFile::read_last_step(out));
  ASSERT_EQ(ltl_run(dir, {"--resume"}, dir / "err", true), 0) << read_text(dir / "err");
  EXPECT_EQ(ResultsFile::read_last_step(out)->iterations, ref.iterations);
  fs::remove_all(dir);
}

// An earlier run's file at the output is replaced only by this run's first step, as without
// --checkpoint: no checkpoint is written over it, and the console says why.
TEST(Checkpoint, NoCheckpointOverAnEarlierRunsFile) {
  const fs::path dir = ltl::testing::temp_dir("checkpoint_earlier");
  const std::string out = (dir / "out.h5").string();
  ASSERT_EQ(ltl_run(dir, {"--set", "algorithm.max_iter=2"}, dir / "err", true), 1);
  ASSERT_TRUE(fs::exists(out));
  const auto before = fs::last_write_time(out);
  const std::string bin = ltl::testing::binary_path("experiments/ltl_run");
  const std::string cmd = "cd '" + dir.string() + "' && '" + bin + "' '" +
                          ltl::testing::source_path("experiments/fig5/fig5.toml") +
                          "' -o out.h5 --set 'algorithm.solver=\"alg2\"' --set "
                          "algorithm.max_iter=300 --checkpoint 0.001 > stdout 2>&1";
  EXPECT_NE(std::system(cmd.c_str()), 0);
  const std::string said = read_text(dir / "stdout");
  EXPECT_NE(said.find("--checkpoint: not saved: " + std::string("out.h5") +
                      " holds an earlier run's results"),
            std::string::npos)
      << said;
  EXPECT_EQ(said.find("checkpoint: step 1 after"), std::string::npos) << said;
  EXPECT_EQ(fs::last_write_time(out), before);  // the earlier run's file, untouched
  fs::remove_all(dir);
}

}  // namespace
