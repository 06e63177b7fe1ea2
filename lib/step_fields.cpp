// The fields of a step made one at a time (step_fields.hpp).
#include "step_fields.hpp"

#include <exception>

#include "derived_fields.hpp"
#include "error.hpp"
#include "mpi_comm.hpp"
#include "results_layout.hpp"

namespace ltl {

namespace {

/// The Cauchy stress sigma of the state's cells and, in plane strain, sigma33 (1.5): the stresses
/// the derived fields need, without P and the pressure in 3-D (Discretization::stresses).
void cauchy_stress(const Discretization& disc, const State& s, Eigen::MatrixXd& sigma,
                   Eigen::VectorXd& sigma33) {
  if (disc.dim() == 3) {
    sigma = disc.cauchy(s);
    return;
  }
  Discretization::Stresses st = disc.stresses(s);
  sigma.swap(st.sigma);
  sigma33.swap(st.sigma33);
}

}  // namespace

StepFields::StepFields(const Solver& solver, const State& state)
    : solver_(solver),
      state_(state),
      rows_(solver.rows_between_steps() && !solver.discretization().whole_field(state.E)) {}

const Eigen::MatrixXd* StepFields::field(const std::string& name, Eigen::MatrixXd& buffer) {
  if (rows_) {
    if (mpi::rank() != 0 || !writing_)
      throw Error(
          cat("internal: under mpirun the fields of a step are asked for by rank 0 "
              "inside StepFields::written only (asked for ",
              name, " on rank ", mpi::rank(), ")"));
    mpi::broadcast(name);  // the other ranks make their part of it (written())
  }
  return make(name, buffer);
}

std::string StepFields::written(const std::function<void()>& write) {
  std::string failure;
  if (!rows_ || mpi::rank() == 0) {
    writing_ = true;
    try {
      write();
    } catch (const std::exception& e) {
      failure = e.what();
    }
    writing_ = false;
    if (!rows_) return failure;
    mpi::broadcast(std::string());  // done: no name is empty
    return mpi::broadcast(failure);
  }
  for (;;) {
    const std::string name = mpi::broadcast(std::string());
    if (name.empty()) break;
    Eigen::MatrixXd part;
    make(name, part);
  }
  return mpi::broadcast(failure);
}

const Eigen::MatrixXd* StepFields::cells(Eigen::MatrixXd&& own, Eigen::MatrixXd& buffer,
                                         int rows_per_cell) const {
  if (rows_) {
    solver_.cells_to_writer(own, buffer, rows_per_cell);
    return mpi::rank() == 0 ? &buffer : nullptr;
  }
  buffer.swap(own);
  return &buffer;
}

const Eigen::MatrixXd* StepFields::make(const std::string& name, Eigen::MatrixXd& buffer) {
  ++made_;
  const Discretization& disc = solver_.discretization();
  const State& s = state_;
  const int d = disc.dim();
  const bool writer = !rows_ || mpi::rank() == 0;
  // Whole on every rank: the nodes' and the contact points' fields.
  if (name == "u" || name == "e" || name == "lambda_c" || name == "beta")
    return writer ? &layout::state_field(s, name, buffer) : nullptr;
  if (name == "contact_pressure" || name == "gap") {
    if (!writer || !disc.points()) return nullptr;
    buffer = name == "gap" ? disc.contact_gap(s) : disc.contact_pressure(s);
    return &buffer;
  }
  if (s.E.size() == 0) return nullptr;  // no cell unknowns (the Signorini problem, section 7)
  // The cells' fields: on the state's cells (a rank's rows), gathered.
  if (name == "E" || name == "lambda") {
    const Eigen::MatrixXd& v = name == "E" ? s.E : s.lambda;
    if (!rows_) return &v;
    solver_.cells_to_writer(v, buffer, d);
    return writer ? &buffer : nullptr;
  }
  if (name == "P") return cells(disc.piola(s), buffer, d);
  if (name == "sigma") return cells(disc.cauchy(s), buffer, d);
  if (name == "sigma33" && d != 2) return nullptr;
  if (name == "sigma33" || name == "pressure") {
    Discretization::Stresses st = disc.stresses(s);
    return cells(Eigen::MatrixXd(name == "sigma33" ? st.sigma33 : st.pressure), buffer, 1);
  }
  const bool per_cell = name == "detF" || name == "stretches" || name == "von_mises";
  const bool per_node = name == "sigma_node" || name == "von_mises_node";
  if (!per_cell && !per_node) return nullptr;
  Eigen::MatrixXd sigma;
  Eigen::VectorXd sigma33;
  cauchy_stress(disc, s, sigma, sigma33);
  if (per_cell) {
    DerivedFields df = cell_fields(s.E, sigma, sigma33);
    Eigen::MatrixXd own;
    if (name == "stretches")
      own.swap(df.stretches);
    else
      own = name == "detF" ? df.detF : df.von_mises;
    return cells(std::move(own), buffer, 1);
  }
  // The nodal stress: every rank's sums over its cells, added up on the writer.
  Eigen::MatrixXd sums = nodal_stress_sums(disc.problem().mesh, disc.cells().vol, sigma, sigma33,
                                           rows_ ? &disc.held_cells() : nullptr);
  Eigen::MatrixXd().swap(sigma);
  if (rows_) mpi::sum_to_writer(sums.data(), sums.size());
  if (!writer) return nullptr;
  DerivedFields df;
  nodal_stress(std::move(sums), df);
  if (name == "sigma_node")
    buffer.swap(df.sigma_node);
  else
    buffer = df.von_mises_node;
  return &buffer;
}

}  // namespace ltl
