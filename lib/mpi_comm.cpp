// The MPI ranks of a distributed run; see mpi_comm.hpp.
#include "mpi_comm.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "error.hpp"

#ifdef LTL_HAVE_MPI
#include <mpi.h>
#include <petscsys.h>
#endif

namespace ltl::mpi {

namespace {
Traffic traffic_;
}  // namespace

std::vector<int> blocks(int n, int ranks) {
  std::vector<int> offset(ranks + 1);
  for (int r = 0; r <= ranks; ++r)
    offset[r] = static_cast<int>(static_cast<long long>(n) * r / ranks);
  return offset;
}

Traffic traffic() {
  return traffic_;
}

Partition partition_of_ranks(const std::vector<int>& rank, int ranks) {
  Partition part;
  part.offset.assign(ranks + 1, 0);
  for (int r : rank) ++part.offset[r + 1];
  for (int r = 0; r < ranks; ++r) part.offset[r + 1] += part.offset[r];
  part.order.resize(rank.size());
  std::vector<int> at(part.offset.begin(), part.offset.end() - 1);
  for (std::size_t i = 0; i < rank.size(); ++i) part.order[at[rank[i]]++] = static_cast<int>(i);
  return part;
}

Partition partition_of(const std::vector<int>& mine, int n) {
  // Counts, then sums of the holders' ranks, then the items out of range; summed first, so that
  // every rank throws the same Error.
  std::vector<double> held(2 * static_cast<std::size_t>(n) + 1, 0.0);
  for (int i : mine) {
    if (i < 0 || i >= n) {
      held[2 * n] += 1;
      continue;
    }
    held[i] += 1;
    held[n + i] += rank();
  }
  sum(held.data(), static_cast<long>(held.size()));
  if (held[2 * n] > 0)
    throw Error(cat(held[2 * n], " items held outside 0 .. ", n - 1,
                    ": the ranks' items are not a partition"));
  std::vector<int> owner(n);
  for (int i = 0; i < n; ++i) {
    if (held[i] != 1)
      throw Error(cat("item ", i, " of ", n, " is held ", held[i],
                      " times over the ranks: the ranks' items are not a partition"));
    owner[i] = static_cast<int>(held[n + i]);
  }
  return partition_of_ranks(owner, size());
}

namespace {
double status_bytes(const char* key) {  // a "Key:   N kB" line of /proc/self/status
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::size_t n = std::strlen(key);
  while (std::getline(in, line))
    if (line.compare(0, n, key) == 0) return 1024.0 * std::atof(line.c_str() + n);
  return 0;
}
}  // namespace

double peak_resident_bytes() {
  return status_bytes("VmHWM:");
}

double resident_bytes() {
  return status_bytes("VmRSS:");
}

ResidentSplit resident_split() {
  return {status_bytes("RssAnon:"), status_bytes("RssFile:"), status_bytes("RssShmem:")};
}

void gather_rows(const Eigen::MatrixXd& own, Eigen::MatrixXd& whole, const Partition& part, int m) {
  const int me = rank();
  whole.resize(static_cast<Eigen::Index>(m) * part.order.size(), own.cols());
  const int* items = part.order.data();
  for_each_run(items + part.offset[me], items + part.offset[me + 1], [&](int first, int n, int at) {
    whole.middleRows(static_cast<Eigen::Index>(m) * first, m * n) =
        own.middleRows(static_cast<Eigen::Index>(m) * at, m * n);
  });
  gather_rows(whole, part, m);
}

namespace {
/// gather_rows_to_writer's checked range of the n items (count < 0: to the last) and this rank's
/// positions [a, b) of its items among them; `own` must hold m rows per item of `items`.
struct WriterItems {
  int count = 0, a = 0, b = 0;
};
WriterItems writer_items(const Eigen::MatrixXd& own, const std::vector<int>& items, int n, int m,
                         int first, int count) {
  if (count < 0) count = n - first;
  if (first < 0 || count < 0 || first + count > n)
    throw Error(cat("gather_rows_to_writer: items ", first, " + ", count, " of ", n));
  if (own.rows() != static_cast<Eigen::Index>(m) * static_cast<Eigen::Index>(items.size()))
    throw Error(cat("gather_rows_to_writer: ", own.rows(), " rows on rank ", rank(), " for ",
                    items.size(), " items (", m, " per item)"));
  WriterItems w;
  w.count = count;
  w.a = static_cast<int>(std::lower_bound(items.begin(), items.end(), first) - items.begin());
  w.b =
      static_cast<int>(std::lower_bound(items.begin(), items.end(), first + count) - items.begin());
  return w;
}

/// Puts one column's rows of the items `item` (m rows each, consecutive in `from`) in place in
/// one column `to` of the rows of items first, first + 1, ...
void put_item_rows(const int* item, const int* end, const double* from, double* to, int m,
                   int first) {
  for_each_run(item, end, [&](int i, int n, int at) {
    std::memcpy(to + static_cast<long>(m) * (i - first), from + static_cast<long>(m) * at,
                sizeof(double) * m * n);
  });
}

/// gather_rows_to_writer on one process: its rows of the items, put in place.
void rows_of_items(const Eigen::MatrixXd& own, Eigen::MatrixXd& block,
                   const std::vector<int>& items, int n, int m, int first, int count) {
  const WriterItems w = writer_items(own, items, n, m, first, count);
  block.resize(static_cast<Eigen::Index>(m) * w.count, own.cols());
  for (Eigen::Index k = 0; k < own.cols(); ++k)
    put_item_rows(items.data() + w.a, items.data() + w.b,
                  own.data() + k * own.rows() + static_cast<long>(m) * w.a,
                  block.data() + k * block.rows(), m, first);
}
}  // namespace

namespace {
/// sum_rows_to_blocks's checks: node sorted, in 0 .. offset.back() - 1, one per row of A.
void check_block_rows(const Eigen::MatrixXd& A, const std::vector<int>& node,
                      const std::vector<int>& offset) {
  if (static_cast<Eigen::Index>(node.size()) != A.rows())
    throw Error(cat("sum_rows_to_blocks: ", A.rows(), " rows for ", node.size(), " nodes"));
  for (std::size_t k = 0; k < node.size(); ++k)
    if (node[k] < 0 || node[k] >= offset.back() || (k > 0 && node[k] <= node[k - 1]))
      throw Error(cat("sum_rows_to_blocks: node ", node[k], " at row ", k, " is outside 0 .. ",
                      offset.back() - 1, " or not after the row before"));
}
/// The rows of A put at their nodes, those of [n0, n0 + block.rows()), added to block.
void add_rows_at_nodes(const Eigen::MatrixXd& A, const std::vector<int>& node, int n0,
                       Eigen::MatrixXd& block) {
  for (std::size_t k = 0; k < node.size(); ++k)
    if (node[k] >= n0 && node[k] < n0 + block.rows())
      block.row(node[k] - n0) += A.row(static_cast<Eigen::Index>(k));
}
}  // namespace

#ifndef LTL_HAVE_MPI

void gather_rows_to_writer(const Eigen::MatrixXd& own, Eigen::MatrixXd& block,
                           const std::vector<int>& items, int n_items, int m, int first,
                           int count) {
  rows_of_items(own, block, items, n_items, m, first, count);
}

bool built() {
  return false;
}
int rank() {
  return 0;
}
int size() {
  return 1;
}
Session::Session(int*, char***) {}
Session::~Session() = default;
void abort(int code) {
  std::exit(code);
}
void barrier() {}
void sum(double*, long) {}
void sum_to_writer(double*, long) {}
void max(double*, long) {}
void broadcast(double*, long) {}
void broadcast(int*, long) {}
std::string broadcast(const std::string& text) {
  return text;
}
void min_max(std::uint64_t v, std::uint64_t& lo, std::uint64_t& hi) {
  lo = hi = v;
}
void gather_rows(Eigen::MatrixXd&, const Partition&, int) {}
void gather_rows(Eigen::VectorXd&, const Partition&) {}
void gather_rows(Eigen::MatrixXd&, const std::vector<int>&, int) {}
void gather_rows(Eigen::VectorXd&, const std::vector<int>&) {}
void gather(double*, const std::vector<int>&) {}
double petsc_bytes_received() {
  return 0;
}
double petsc_messages_received() {
  return 0;
}
bool option(const char*) {
  return false;
}
void set_option(const char*, bool, const char*) {}
double petsc_reductions() {
  return 0;
}
void sum_rows_to_blocks(const Eigen::MatrixXd& A, const std::vector<int>& node,
                        const std::vector<int>& offset, Eigen::MatrixXd& block) {
  check_block_rows(A, node, offset);
  block = Eigen::MatrixXd::Zero(offset[1] - offset[0], A.cols());
  add_rows_at_nodes(A, node, offset[0], block);
}

#else

namespace {
using clock_type = std::chrono::steady_clock;
double seconds_since(clock_type::time_point t0) {
  return std::chrono::duration<double>(clock_type::now() - t0).count();
}
bool up = false;
int rank_ = 0, size_ = 1;
constexpr long kReducePiece = 1L << 17;  ///< doubles a reduction takes at a time (1 MB)
std::vector<double> send_, recv_;
std::vector<int> counts_, displs_;

void check(int err, const char* call) {
  if (err != MPI_SUCCESS) throw Error(cat("MPI: ", call, " failed (error ", err, ")"));
}
}  // namespace

bool built() {
  return true;
}
int rank() {
  return rank_;
}
int size() {
  return size_;
}

Session::Session(int* argc, char*** argv) {
  int already = 0;
  MPI_Initialized(&already);
  if (!already) check(MPI_Init(argc, argv), "MPI_Init");
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  PetscBool petsc = PETSC_FALSE;
  PetscInitialized(&petsc);
  if (!petsc) {
    PetscOptionsSetValue(nullptr, "-no_signal_handler", nullptr);
    if (PetscInitializeNoArguments()) throw Error("PETSc could not be initialized");
  }
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
  up = true;
}

Session::~Session() {
  PetscFinalize();
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (!finalized) MPI_Finalize();
  up = false;
}

void abort(int code) {
  if (up && size_ > 1) MPI_Abort(MPI_COMM_WORLD, code);
  std::exit(code);
}

void barrier() {
  if (up) MPI_Barrier(MPI_COMM_WORLD);
}

namespace {
/// x[i] = op over the ranks of x[i], in place, in pieces of kReducePiece doubles: Open MPI's
/// temporary buffer of a reduction (which it keeps) is of one piece, not of a whole #nodes x dim
/// array. One call in the traffic counters.
void allreduce_in_pieces(double* x, long n, MPI_Op op) {
  if (!up || size_ == 1) return;
  const auto t0 = clock_type::now();
  for (long i = 0; i < n; i += kReducePiece)
    check(MPI_Allreduce(MPI_IN_PLACE, x + i, static_cast<int>(std::min(kReducePiece, n - i)),
                        MPI_DOUBLE, op, MPI_COMM_WORLD),
          "MPI_Allreduce");
  traffic_.bytes += 8.0 * n;
  traffic_.calls += 1;
  traffic_.seconds += seconds_since(t0);
}
}  // namespace

void sum(double* x, long n) {
  allreduce_in_pieces(x, n, MPI_SUM);
}

void sum_to_writer(double* x, long n) {
  if (!up || size_ == 1) return;
  const auto t0 = clock_type::now();
  const bool writer = rank_ == 0;
  for (long i = 0; i < n; i += kReducePiece)  // in pieces, as allreduce_in_pieces
    check(MPI_Reduce(writer ? MPI_IN_PLACE : x + i, writer ? x + i : nullptr,
                     static_cast<int>(std::min(kReducePiece, n - i)), MPI_DOUBLE, MPI_SUM, 0,
                     MPI_COMM_WORLD),
          "MPI_Reduce");
  if (writer) traffic_.bytes += 8.0 * n;
  traffic_.calls += 1;
  traffic_.seconds += seconds_since(t0);
}

void max(double* x, long n) {
  allreduce_in_pieces(x, n, MPI_MAX);
}

namespace {
void broadcast_bytes(void* x, long n, MPI_Datatype type, int bytes_each) {
  if (!up || size_ == 1) return;
  const auto t0 = clock_type::now();
  check(MPI_Bcast(x, static_cast<int>(n), type, 0, MPI_COMM_WORLD), "MPI_Bcast");
  if (rank_ != 0) traffic_.bytes += static_cast<double>(bytes_each) * n;
  traffic_.calls += 1;
  traffic_.seconds += seconds_since(t0);
}
}  // namespace

void broadcast(double* x, long n) {
  broadcast_bytes(x, n, MPI_DOUBLE, 8);
}
void broadcast(int* x, long n) {
  broadcast_bytes(x, n, MPI_INT, 4);
}
std::string broadcast(const std::string& text) {
  int n = static_cast<int>(text.size());
  broadcast(&n, 1);
  std::string out = rank_ == 0 ? text : std::string(static_cast<std::size_t>(n), '\0');
  broadcast_bytes(out.data(), n, MPI_CHAR, 1);
  return out;
}

void min_max(std::uint64_t v, std::uint64_t& lo, std::uint64_t& hi) {
  lo = hi = v;
  if (!up || size_ == 1) return;
  unsigned long long in = v, a = 0, b = 0;
  check(MPI_Allreduce(&in, &a, 1, MPI_UNSIGNED_LONG_LONG, MPI_MIN, MPI_COMM_WORLD),
        "MPI_Allreduce");
  check(MPI_Allreduce(&in, &b, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, MPI_COMM_WORLD),
        "MPI_Allreduce");
  lo = a;
  hi = b;
}

namespace {
/// Allgatherv of `cols` columns of `n` rows each, rank r owning the rows [m offset[r], m
/// offset[r + 1]) of every column (col(k) at data + k * ld); with `order`, the rows
/// [m order[j], m order[j] + m) for offset[r] <= j < offset[r + 1]. One column in blocks of
/// the ranks' order gathers in place (MPI_IN_PLACE): no buffer of the array is made or kept.
void gather_columns(double* data, long ld, int cols, const std::vector<int>& offset, int m,
                    const std::vector<int>* order = nullptr) {
  if (!up || size_ == 1) return;
  const auto t0 = clock_type::now();
  const int P = size_;
  counts_.resize(P);
  displs_.resize(P);
  long total = 0;
  for (int r = 0; r < P; ++r) {
    counts_[r] = cols * m * (offset[r + 1] - offset[r]);
    displs_[r] = static_cast<int>(total);
    total += counts_[r];
  }
  if (cols == 1 && !order) {
    check(MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, data, counts_.data(), displs_.data(),
                         MPI_DOUBLE, MPI_COMM_WORLD),
          "MPI_Allgatherv");
  } else {
    const long first = static_cast<long>(m) * offset[rank_];
    const int own = m * (offset[rank_ + 1] - offset[rank_]);
    send_.resize(static_cast<std::size_t>(cols) * own);
    recv_.resize(total);
    // The items order[j0 .. j1) (sorted: runs of consecutive items), their m rows of every column
    // copied between A and a buffer (column blocks of m (j1 - j0) rows).
    auto copy = [&](double* buffer, int j0, int j1, bool to_buffer) {
      const int rows = m * (j1 - j0);
      for_each_run(order->data() + j0, order->data() + j1, [&](int first, int n, int at_item) {
        const long at = static_cast<long>(m) * at_item;  // the run's first row in the buffer
        for (int k = 0; k < cols; ++k) {
          double* a = data + k * ld + static_cast<long>(m) * first;
          double* b = buffer + static_cast<long>(k) * rows + at;
          if (to_buffer)
            std::memcpy(b, a, sizeof(double) * m * n);
          else
            std::memcpy(a, b, sizeof(double) * m * n);
        }
      });
    };
    if (order)
      copy(send_.data(), offset[rank_], offset[rank_ + 1], true);
    else
      for (int k = 0; k < cols; ++k)
        std::memcpy(send_.data() + static_cast<long>(k) * own, data + k * ld + first,
                    sizeof(double) * own);
    check(MPI_Allgatherv(send_.data(), counts_[rank_], MPI_DOUBLE, recv_.data(), counts_.data(),
                         displs_.data(), MPI_DOUBLE, MPI_COMM_WORLD),
          "MPI_Allgatherv");
    for (int r = 0; r < P; ++r) {
      if (r == rank_) continue;
      if (order) {
        copy(recv_.data() + displs_[r], offset[r], offset[r + 1], false);
        continue;
      }
      const int rows = m * (offset[r + 1] - offset[r]);
      const long at = static_cast<long>(m) * offset[r];
      for (int k = 0; k < cols; ++k)
        std::memcpy(data + k * ld + at, recv_.data() + displs_[r] + static_cast<long>(k) * rows,
                    sizeof(double) * rows);
    }
  }
  traffic_.bytes += 8.0 * (total - counts_[rank_]);
  traffic_.calls += 1;
  traffic_.seconds += seconds_since(t0);
}
}  // namespace

void gather_rows(Eigen::MatrixXd& A, const std::vector<int>& offset, int rows_per_item) {
  if (A.size() == 0) return;
  gather_columns(A.data(), A.rows(), static_cast<int>(A.cols()), offset, rows_per_item);
}

void gather_rows(Eigen::VectorXd& v, const std::vector<int>& offset) {
  if (v.size() == 0) return;
  gather_columns(v.data(), v.size(), 1, offset, 1);
}

void gather(double* x, const std::vector<int>& offset) {
  gather_columns(x, offset.back(), 1, offset, 1);
}

// A whole per-cell array, gathered once per ALG2 phase: column by column, so that the buffers
// hold one column, and freed afterwards (the per-iteration gathers of the contact points keep
// theirs).
void gather_rows(Eigen::MatrixXd& A, const Partition& part, int rows_per_item) {
  for (Eigen::Index k = 0; k < A.cols(); ++k)
    gather_columns(A.data() + k * A.rows(), A.rows(), 1, part.offset, rows_per_item, &part.order);
  std::vector<double>().swap(send_);
  std::vector<double>().swap(recv_);
}

void gather_rows(Eigen::VectorXd& v, const Partition& part) {
  if (v.size() == 0) return;
  gather_columns(v.data(), v.size(), 1, part.offset, 1, &part.order);
}

void gather_rows_to_writer(const Eigen::MatrixXd& own, Eigen::MatrixXd& block,
                           const std::vector<int>& items, int n_items, int m, int first,
                           int count) {
  if (!up || size_ == 1) return rows_of_items(own, block, items, n_items, m, first, count);
  const WriterItems w = writer_items(own, items, n_items, m, first, count);
  const int P = size_, me = rank_;
  const bool writer = me == 0;
  const auto t0 = clock_type::now();
  // How many of the block's items each rank has, and which: the writer places their rows by them.
  const int mine = w.b - w.a;
  std::vector<int> counts(writer ? P : 0), displs(writer ? P : 0);
  check(MPI_Gather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD), "MPI_Gather");
  long total = 0;
  for (int r = 0; writer && r < P; ++r) {
    displs[r] = static_cast<int>(total);
    total += counts[r];
  }
  if (writer && total != w.count)
    throw Error(
        cat("gather_rows_to_writer: the ranks hold ", total, " of items ", first, " + ", w.count));
  std::vector<int> item(static_cast<std::size_t>(total));
  check(MPI_Gatherv(items.data() + w.a, mine, MPI_INT, item.data(), counts.data(), displs.data(),
                    MPI_INT, 0, MPI_COMM_WORLD),
        "MPI_Gatherv");
  for (int r = 0; writer && r < P; ++r) counts[r] *= m, displs[r] *= m;  // in rows
  if (writer)
    block.resize(static_cast<Eigen::Index>(m) * w.count, own.cols());
  else
    block = Eigen::MatrixXd();
  if (writer) recv_.resize(static_cast<std::size_t>(m) * total);
  // Each column of `own` sends the rank's rows of those items as they are; the writer puts them
  // in place, run by run of consecutive items.
  for (Eigen::Index k = 0; k < own.cols(); ++k) {
    const double* rows = own.data() + k * own.rows() + static_cast<long>(m) * w.a;
    check(MPI_Gatherv(rows, m * mine, MPI_DOUBLE, recv_.data(), counts.data(), displs.data(),
                      MPI_DOUBLE, 0, MPI_COMM_WORLD),
          "MPI_Gatherv");
    if (writer)
      put_item_rows(item.data(), item.data() + total, recv_.data(), block.data() + k * block.rows(),
                    m, first);
  }
  std::vector<double>().swap(recv_);
  if (writer) traffic_.bytes += (8.0 * m * own.cols() + 4.0) * (total - mine);
  traffic_.calls += 1;
  traffic_.seconds += seconds_since(t0);
}

void sum_rows_to_blocks(const Eigen::MatrixXd& A, const std::vector<int>& node,
                        const std::vector<int>& offset, Eigen::MatrixXd& block) {
  check_block_rows(A, node, offset);
  const int P = size_, cols = static_cast<int>(A.cols());
  const int n0 = offset[rank_], n1 = offset[rank_ + 1];
  block = Eigen::MatrixXd::Zero(n1 - n0, cols);
  if (!up || P == 1) return add_rows_at_nodes(A, node, n0, block);
  const auto t0 = clock_type::now();
  // The rows to block r are the run of sorted nodes in [offset[r], offset[r + 1]): in order.
  std::vector<int> send_rows(P), recv_rows(P), send_at(P + 1, 0), recv_at(P + 1, 0);
  for (int r = 0; r < P; ++r) {
    send_at[r + 1] =
        static_cast<int>(std::lower_bound(node.begin(), node.end(), offset[r + 1]) - node.begin());
    send_rows[r] = send_at[r + 1] - send_at[r];
  }
  check(MPI_Alltoall(send_rows.data(), 1, MPI_INT, recv_rows.data(), 1, MPI_INT, MPI_COMM_WORLD),
        "MPI_Alltoall");
  for (int r = 0; r < P; ++r) recv_at[r + 1] = recv_at[r] + recv_rows[r];
  std::vector<int> nodes_in(recv_at[P]);
  check(MPI_Alltoallv(node.data(), send_rows.data(), send_at.data(), MPI_INT, nodes_in.data(),
                      recv_rows.data(), recv_at.data(), MPI_INT, MPI_COMM_WORLD),
        "MPI_Alltoallv");
  // The values row by row (cols per row), in the nodes' order.
  send_.resize(static_cast<std::size_t>(cols) * node.size());
  for (Eigen::Index k = 0; k < A.rows(); ++k)
    for (int j = 0; j < cols; ++j) send_[static_cast<std::size_t>(cols) * k + j] = A(k, j);
  recv_.resize(static_cast<std::size_t>(cols) * nodes_in.size());
  counts_.resize(2 * P);
  displs_.resize(2 * P);
  int* sc = counts_.data();
  int* rc = counts_.data() + P;
  int* sd = displs_.data();
  int* rd = displs_.data() + P;
  for (int r = 0; r < P; ++r) {
    sc[r] = cols * send_rows[r];
    sd[r] = cols * send_at[r];
    rc[r] = cols * recv_rows[r];
    rd[r] = cols * recv_at[r];
  }
  check(MPI_Alltoallv(send_.data(), sc, sd, MPI_DOUBLE, recv_.data(), rc, rd, MPI_DOUBLE,
                      MPI_COMM_WORLD),
        "MPI_Alltoallv");
  for (std::size_t k = 0; k < nodes_in.size(); ++k)  // from rank 0 up: a fixed order
    for (int j = 0; j < cols; ++j)
      block(nodes_in[k] - n0, j) += recv_[static_cast<std::size_t>(cols) * k + j];
  std::vector<double>().swap(send_);
  std::vector<double>().swap(recv_);
  traffic_.bytes += (8.0 * cols + 4.0) * (recv_at[P] - recv_rows[rank_]);
  traffic_.calls += 3;
  traffic_.seconds += seconds_since(t0);
}

double petsc_bytes_received() {
  return petsc_irecv_len + petsc_recv_len;
}
double petsc_messages_received() {
  return petsc_irecv_ct + petsc_recv_ct;
}
bool option(const char* name) {
  PetscBool set = PETSC_FALSE;
  PetscOptionsHasName(nullptr, nullptr, name, &set);
  return set == PETSC_TRUE;
}
void set_option(const char* name, bool on, const char* value) {
  if (on)
    PetscOptionsSetValue(nullptr, name, value);
  else
    PetscOptionsClearValue(nullptr, name);
}
double petsc_reductions() {
  return petsc_allreduce_ct;
}

#endif

}  // namespace ltl::mpi
