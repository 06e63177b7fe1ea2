// The fields of a step made one at a time and read by blocks (step_fields.hpp).
#include "step_fields.hpp"

#include <exception>
#include <sstream>

#include "derived_fields.hpp"
#include "error.hpp"
#include "fe.hpp"
#include "mpi_comm.hpp"
#include "results_fields.hpp"
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

/// Is `name` a field of the cells made from E (sigma33: in plane strain only)?
bool cell_field(const std::string& name, int dim) {
  for (const char* f : {"E", "lambda", "P", "sigma", "pressure", "detF", "stretches", "von_mises"})
    if (name == f) return true;
  return name == "sigma33" && dim == 2;
}

}  // namespace

StepFields::StepFields(const Solver& solver, const State& state, Fields fields)
    : solver_(solver),
      state_(state),
      rows_(solver.rows_between_steps() && !solver.discretization().whole_field(state.E)),
      state_only_(fields == Fields::State) {}

std::pair<Eigen::Index, Eigen::Index> StepFields::open(const std::string& name) {
  if (state_only_ && name != kMeshCells && name != kMeshX) {  // decided on rank 0 alone: the
    const Field* f = find_field(name);                        // others are asked for nothing
    if (!f || f->source != Source::State) return {0, 0};
  }
  Eigen::MatrixXd none;
  return ask("open " + name, none);
}

void StepFields::read(const std::string& name, Eigen::Index first, Eigen::Index count,
                      Eigen::MatrixXd& rows) {
  const auto it = open_.find(name);
  if (it != open_.end() && it->second.kind == Part::Kind::Here) {  // whole here: no collective
    ++reads_;
    rows = it->second.data().middleRows(first, count);
    return;
  }
  ask(cat("read ", name, " ", first, " ", count), rows);
}

void StepFields::close(const std::string& name) noexcept {
  open_.erase(name);
  if (rows_) closed_ += "close " + name + "\n";  // the other ranks release it with the next request
}

std::pair<Eigen::Index, Eigen::Index> StepFields::ask(const std::string& request,
                                                      Eigen::MatrixXd& rows) {
  if (!rows_) return serve(request, rows);
  if (mpi::rank() != 0 || !writing_)
    throw Error(
        cat("internal: under mpirun the fields of a step are asked for by rank 0 inside "
            "StepFields::written only (asked: ",
            request, " on rank ", mpi::rank(), ")"));
  const std::string sent = closed_ + request;
  closed_.clear();
  mpi::broadcast(sent);  // the other ranks serve it too (written())
  return serve(sent, rows);
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
    open_.clear();
    closed_.clear();
    if (!rows_) return failure;
    mpi::broadcast(std::string());  // done: no request is empty
    return mpi::broadcast(failure);
  }
  for (;;) {
    const std::string request = mpi::broadcast(std::string());
    if (request.empty()) break;
    Eigen::MatrixXd none;
    serve(request, none);
  }
  open_.clear();
  return mpi::broadcast(failure);
}

std::pair<Eigen::Index, Eigen::Index> StepFields::serve(const std::string& request,
                                                        Eigen::MatrixXd& rows) {
  std::istringstream lines(request);
  std::string line;
  std::pair<Eigen::Index, Eigen::Index> size{0, 0};
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::string verb, name;
    words >> verb >> name;
    if (verb == "close") {
      open_.erase(name);
    } else if (verb == "open") {
      make(name);
      const auto it = open_.find(name);
      size = it == open_.end() ? std::make_pair(Eigen::Index(0), Eigen::Index(0))
                               : std::make_pair(it->second.rows, it->second.cols);
    } else if (verb == "read") {
      Eigen::Index first = -1, count = -1;
      words >> first >> count;
      const auto it = open_.find(name);
      if (it == open_.end() || first < 0 || count < 0 || first + count > it->second.rows)
        throw Error(cat("internal: StepFields on rank ", mpi::rank(), ": cannot serve '", line,
                        "' (", it == open_.end() ? "not open" : "rows out of range", ")"));
      ++reads_;
      const Part& p = it->second;
      const bool writer = !rows_ || mpi::rank() == 0;
      if (p.kind == Part::Kind::Here) {  // read where it is (read()), never asked for
        throw Error(cat("internal: StepFields: '", line, "' asked of a field whole on rank 0"));
      } else if (p.kind == Part::Kind::Cells) {
        if (first % p.m || count % p.m)
          throw Error(cat("internal: StepFields: rows ", first, " + ", count, " of ", name,
                          " are not whole cells of ", p.m, " rows"));
        solver_.cells_to_writer(p.data(), rows, p.m, static_cast<int>(first / p.m),
                                static_cast<int>(count / p.m));
      } else if (p.kind == Part::Kind::NodeRows) {
        solver_.nodes_to_writer(p.data(), rows, static_cast<int>(first), static_cast<int>(count));
      } else {  // the nodal stress of nodes first .. first + count - 1, summed over the ranks
        const Discretization& disc = solver_.discretization();
        // The held cells' volumes, in their order (every cell's on a discretization of every
        // cell), or those made when it was opened (Part::volume).
        // On a rank's cells, their own mesh (Discretization::part()).
        const Eigen::VectorXd& vol = p.volume.size() ? p.volume : disc.cells().vol;
        Eigen::MatrixXd sums =
            rows_ && disc.partial()
                ? nodal_stress_sums(disc.part(), disc.cells().node, disc.num_nodes(), vol, p.own,
                                    p.sigma33, static_cast<int>(first), static_cast<int>(count))
                : nodal_stress_sums(disc.problem().mesh, vol, p.own, p.sigma33,
                                    rows_ ? &disc.held_cells() : nullptr, static_cast<int>(first),
                                    static_cast<int>(count));
        if (rows_) mpi::sum_to_writer(sums.data(), sums.size());
        if (!writer) continue;
        DerivedFields df;
        nodal_stress(std::move(sums), df);
        if (p.von_mises)
          rows = df.von_mises_node;
        else
          rows.swap(df.sigma_node);
      }
    } else {
      throw Error(cat("internal: StepFields: unknown request '", line, "'"));
    }
  }
  return size;
}

void StepFields::make(const std::string& name) {
  ++made_;
  open_.erase(name);
  const Discretization& disc = solver_.discretization();
  const State& s = state_;
  const int d = disc.dim();
  const bool writer = !rows_ || mpi::rank() == 0;
  Part& p = open_[name];
  if (name == kMeshCells) {  // each rank's cells' nodes, from its part, gathered by blocks
    const Mesh& part = disc.part();
    const int npc = part.nodes_per_cell();
    if (!rows_ && disc.partial())
      throw Error(
          cat("internal: StepFields: the mesh's connectivity from the ranks' parts needs "
              "a state on the ranks' rows (rank ",
              mpi::rank(), ")"));
    p.own.resize(part.num_cells(), npc);
    for (int k = 0; k < part.num_cells(); ++k)
      for (int a = 0; a < npc; ++a) p.own(k, a) = disc.part_node(part.cells(k, a));
    p.m = 1;
    p.rows = disc.num_cells();
    p.cols = npc;
    if (rows_) p.kind = Part::Kind::Cells;  // else whole here (every cell: the mesh itself)
    return;
  }
  if (name == kMeshX) {  // X on the ranks' ghost layers' rows, read like u below
    const Eigen::MatrixXd* X = solver_.reference_rows();
    if (!rows_ || !X)
      throw Error(
          cat("internal: StepFields: the mesh's positions from the ranks' rows need a state "
              "and the positions on the ranks' ghost layers (rank ",
              mpi::rank(), ")"));
    p.state = X;
    p.kind = Part::Kind::NodeRows;
    p.rows = disc.num_nodes();
    p.cols = d;
    return;
  }
  // u on the ranks' ghost layers' rows (the state between steps, Solver::state_rows): each
  // rank's owned nodes' rows, added up on the writer block by block.
  if (name == "u" && rows_ && s.u.rows() != disc.num_nodes()) {
    p.state = &s.u;
    p.kind = Part::Kind::NodeRows;
    p.rows = disc.num_nodes();
    p.cols = s.u.cols();
    return;
  }
  // Whole on every rank: the nodes' and the contact points' fields, read on the writer alone.
  if (name == "u" || name == "e" || name == "lambda_c" || name == "beta") {
    const Eigen::MatrixXd& v = layout::state_field(s, name, p.own);
    if (&v != &p.own) p.state = &v;
  } else if (name == "contact_pressure" || name == "gap") {
    if (writer && disc.points())
      p.own = name == "gap" ? disc.contact_gap(s) : disc.contact_pressure(s);
  } else if (s.E.size() == 0) {  // no cell unknowns (the Signorini problem, section 7)
  } else if (name == "sigma_node" || name == "von_mises_node") {
    // The nodal stress: every rank's sums over its cells, added up on the writer block by block.
    cauchy_stress(disc, s, p.own, p.sigma33);
    // A whole state on a discretization of some cells: every cell's volume and nodes, on a rank
    // that has kept the mesh's connectivity (with the Newton phase:
    // Discretization::release_mesh_cells).
    if (!rows_ && disc.partial()) {
      if (disc.problem().mesh.cells.rows() == 0)
        throw Error(
            cat("the nodal stress of a whole state needs the mesh's connectivity, which "
                "rank ",
                mpi::rank(),
                " released after its set-up: it is made from the state on the ranks' "
                "rows"));
      p.volume = cell_volumes(disc.problem().mesh);
    }
    p.kind = Part::Kind::Nodes;
    p.von_mises = name == "von_mises_node";
    p.rows = disc.problem().mesh.num_nodes();
    p.cols = p.von_mises ? 1 : 9;
    return;
  } else if (cell_field(name, d)) {
    // The cells' fields: on the state's cells (a rank's rows), gathered block by block.
    const bool tensor = name == "E" || name == "lambda" || name == "P" || name == "sigma";
    p.m = tensor ? d : 1;
    if (name == "E" || name == "lambda") {
      p.state = name == "E" ? &s.E : &s.lambda;
    } else if (name == "P") {
      p.own = disc.piola(s);
    } else if (name == "sigma") {
      p.own = disc.cauchy(s);
    } else if (name == "sigma33" || name == "pressure") {
      Discretization::Stresses st = disc.stresses(s);
      p.own = name == "sigma33" ? st.sigma33 : st.pressure;
    } else {
      Eigen::MatrixXd sigma;
      Eigen::VectorXd sigma33;
      cauchy_stress(disc, s, sigma, sigma33);
      DerivedFields df = cell_fields(s.E, sigma, sigma33);
      if (name == "stretches")
        p.own.swap(df.stretches);
      else
        p.own = name == "detF" ? df.detF : df.von_mises;
    }
    if (!rows_) {  // whole here: its size as made
      p.rows = p.data().rows();
      p.cols = p.data().cols();
      return;
    }
    p.kind = Part::Kind::Cells;  // each rank's rows (their number checked by the gather)
    p.rows = static_cast<Eigen::Index>(p.m) * disc.num_cells();
    p.cols = tensor ? d : name == "stretches" ? 3 : 1;
    return;
  }
  if (p.data().size() && writer) {
    p.rows = p.data().rows();
    p.cols = p.data().cols();
    return;
  }
  open_.erase(name);  // none (or, on a rank that does not write, a field read on the writer)
}

}  // namespace ltl
