// The MPI ranks of a distributed ALG2 run (lib/alg2_mpi.cpp), behind plain C++: the world's size
// and rank, the session (MPI and PETSc initialized once, finalized once), and the few collectives
// the distributed iteration needs (sums, row-block gathers, min/max), each counted in bytes.
//
// Built with MPI only when CMake's LTL_WITH_MPI is on (it needs PETSc: the distributed global
// step, lib/mpi_global.hpp); only mpi_comm.cpp and mpi_global.cpp see MPI's and PETSc's headers.
// Without it every call is a no-op on one rank (size() = 1, rank() = 0): the serial package.
//
// Bytes: the payload each collective brings INTO this rank (a sum of n doubles: 8 n; a gather:
// the other ranks' blocks), counted here; PETSc's own messages (the distributed KSP's
// matrix-vector products and AMG levels) are PETSc's counters, petsc_bytes_received().
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cstdint>
#include <exception>
#include <string>
#include <vector>

namespace ltl::mpi {

/// Built with MPI (and PETSc)?
bool built();
/// The ranks of MPI_COMM_WORLD once a Session is up; 0 and 1 otherwise.
int rank();
int size();

/// MPI then PETSc initialized in the constructor, PETSc then MPI finalized in the destructor
/// (PETSc without its signal handlers, errors returned rather than printed). One per process,
/// in main(); without MPI it does nothing.
class Session {
 public:
  Session(int* argc, char*** argv);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
};

/// Ends every rank at once (a rank that failed alone would leave the others waiting).
[[noreturn]] void abort(int code);
/// May this rank destroy its PETSc objects now? Not while an exception unwinds them on several
/// ranks: the error may be this rank's alone (memory exhausted in a set-up), and their
/// destruction is collective (MUMPS's), so the rank would wait for the others, which wait for it
/// in their next collective. They are left to the job's end (ltl_run's MPI_Abort). A collective
/// stop (a signal) destroys them after its handler, not while unwinding.
inline bool collective_teardown() {
  return size() == 1 || std::uncaught_exceptions() == 0;
}
void barrier();

/// Contiguous blocks of n items over the ranks: rank r owns [offset[r], offset[r + 1]).
std::vector<int> blocks(int n, int ranks);

/// In place: x[i] = sum over ranks of x[i] (in pieces of 1 MB: MPI's buffers stay that size).
void sum(double* x, long n);
/// The same to rank 0 alone (the results writer): there x[i] = sum over ranks of x[i]; elsewhere
/// x is left as it was (and may be released).
void sum_to_writer(double* x, long n);
/// In place: x[i] = the largest over the ranks of x[i].
void max(double* x, long n);
/// In place: every rank gets rank 0's x[0 .. n) (a resumed run's start, read by rank 0 alone).
void broadcast(double* x, long n);
void broadcast(int* x, long n);
/// Rank 0's text, on every rank (a path, an error message; the argument is ignored elsewhere).
std::string broadcast(const std::string& text);
/// Over the ranks: the smallest and the largest of v (the check that every rank holds the same).
void min_max(std::uint64_t v, std::uint64_t& lo, std::uint64_t& hi);

/// A row-block gather: rank r holds the rows [rows_per_item * offset[r], rows_per_item *
/// offset[r + 1]) of A (column-major, the other rows anything); afterwards every rank holds all of
/// them.
void gather_rows(Eigen::MatrixXd& A, const std::vector<int>& offset, int rows_per_item);
void gather_rows(Eigen::VectorXd& v, const std::vector<int>& offset);
/// The same for a plain array of n values where rank r holds [offset[r], offset[r + 1]). These
/// gathers of one column (a vector, a plain array, a one-column A) are in place: no buffer of
/// the array is made or kept.
void gather(double* x, const std::vector<int>& offset);

/// Items (cells) dealt to the ranks in any sets: rank r holds the items order[j], offset[r] <= j
/// < offset[r + 1], each rank's sorted (cell_partition in mpi_global.hpp).
struct Partition {
  std::vector<int> order, offset;
  /// Rank r's items, sorted.
  std::vector<int> items(int r) const {
    return {order.begin() + offset[r], order.begin() + offset[r + 1]};
  }
  /// Each item's rank (what partition_of_ranks takes).
  std::vector<int> owners() const {
    std::vector<int> rank(order.size());
    for (std::size_t r = 0; r + 1 < offset.size(); ++r)
      for (int j = offset[r]; j < offset[r + 1]; ++j) rank[order[j]] = static_cast<int>(r);
    return rank;
  }
};
/// The Partition of items 0 .. rank.size() - 1 where item i is rank rank[i]'s (0 <= rank[i] <
/// ranks).
Partition partition_of_ranks(const std::vector<int>& rank, int ranks);
/// The Partition of the items 0 .. n - 1 in which rank r's items are its `mine` (any order).
/// Collective: one sum of 2 n values. An Error, on every rank, names an item outside 0 .. n - 1,
/// or one that the ranks hold no time or more than once.
Partition partition_of(const std::vector<int>& mine, int n);

/// Calls f(first, n, at) for each maximal run first, first + 1, ..., first + n - 1 of
/// consecutive items in the sorted `items`, at its position in them (one run when they are
/// 0 .. n - 1): whole-block arithmetic on a rank's cells, which are runs of the cell index, and
/// on its arrays of those cells alone (rows in the order of `items`).
template <class F>
void for_each_run(const int* items, const int* end, F&& f) {
  for (const int* j = items; j < end;) {
    const int* k = j + 1;
    while (k < end && *k == *(k - 1) + 1) ++k;
    f(*j, static_cast<int>(k - j), static_cast<int>(j - items));
    j = k;
  }
}
template <class F>
void for_each_run(const std::vector<int>& items, F&& f) {
  for_each_run(items.data(), items.data() + items.size(), f);
}

/// The position of `item` in the sorted `items` (a rank's cells, nodes or points), -1 when it is
/// not one of them: a rank's row of an item of the whole numbering.
inline int position_in(const std::vector<int>& items, int item) {
  const auto j = std::lower_bound(items.begin(), items.end(), item);
  return j != items.end() && *j == item ? static_cast<int>(j - items.begin()) : -1;
}

/// The row gather of a Partition: rank r holds the rows [rows_per_item i, rows_per_item (i + 1))
/// of its items i; afterwards every rank holds all of them. A matrix goes column by column (the
/// buffers hold one column) and the buffers are freed afterwards: a whole per-cell array is
/// gathered once per ALG2 phase, not per iteration.
void gather_rows(Eigen::MatrixXd& A, const Partition& part, int rows_per_item);
void gather_rows(Eigen::VectorXd& v, const Partition& part);
/// The same from the rank's rows alone: `own` holds rows_per_item rows per item of this rank,
/// the k-th item's at rows_per_item k; `whole` (resized) gets every item's rows on every rank.
void gather_rows(const Eigen::MatrixXd& own, Eigen::MatrixXd& whole, const Partition& part,
                 int rows_per_item);

/// The same to rank 0 alone (the results writer), for the items first .. first + count - 1 of
/// n_items (count < 0: every item from first), from each rank's own rows of its `items` (sorted,
/// each item on one rank; no rank needs the partition's order): there `block` gets their
/// rows_per_item rows each, in item order; on the other ranks it is released (left empty). Each
/// rank sends the numbers of its items in the block, then their rows. Read a block of items at a
/// time, no rank holds a whole array it does not own. Column by column, like the gathers above.
void gather_rows_to_writer(const Eigen::MatrixXd& own, Eigen::MatrixXd& block,
                           const std::vector<int>& items, int n_items, int rows_per_item,
                           int first = 0, int count = -1);

/// [(4.5)] The ranks' parts of a nodal array, summed on the ranks' blocks of the nodes: rank r
/// holds rows A.row(k) at the nodes node[k] (sorted, increasing; the same node may be on other
/// ranks too: the nodes of a rank's cells); afterwards `block` (resized) holds on rank r the rows
/// offset[r] .. offset[r + 1] - 1 (blocks(#nodes, size())) of the sum over the ranks of their
/// rows put at their nodes, zero where no rank has a row. Each rank sends its rows of each block
/// to the block's rank with their node numbers (MPI_Alltoallv), which adds them in rank order:
/// the rank's rows out and its block's in, no array of every node (collective). An Error names
/// a node outside the blocks or out of order.
void sum_rows_to_blocks(const Eigen::MatrixXd& A, const std::vector<int>& node,
                        const std::vector<int>& offset, Eigen::MatrixXd& block);

/// What our collectives moved since the start: bytes received (payload), calls, wall seconds.
struct Traffic {
  double bytes = 0, calls = 0, seconds = 0;
};
Traffic traffic();
/// PETSc's own point-to-point payload received by this rank since the start (its log counters:
/// the distributed KSP), and its count of reductions.
double petsc_bytes_received();
/// ... and the count of those messages (point-to-point receives).
double petsc_messages_received();
double petsc_reductions();

/// Is the PETSc option `name` set (PETSC_OPTIONS in the environment, e.g. "-ltl_mpi_replicated")?
/// False without MPI.
bool option(const char* name);
/// Sets (or with on = false clears) the PETSc option `name`, with `value` if not null (tests;
/// nothing without MPI).
void set_option(const char* name, bool on, const char* value = nullptr);

/// Peak resident memory of this process (VmHWM, bytes; 0 where /proc is missing).
double peak_resident_bytes();
/// Resident memory of this process now (VmRSS, bytes; 0 where /proc is missing).
double resident_bytes();
/// The resident memory now split as the kernel counts it (bytes; 0 where /proc is missing):
/// anonymous pages (RssAnon: the heap, the process's own data), file-backed pages (RssFile: the
/// executable's and the libraries' code and read-only data, shared by the processes of a node
/// that map the same files) and shared memory (RssShmem: MPI's shared-memory transport).
struct ResidentSplit {
  double anonymous = 0, file = 0, shared_memory = 0;
};
ResidentSplit resident_split();

}  // namespace ltl::mpi
