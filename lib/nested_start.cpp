#include "nested_start.hpp"

#include <chrono>
#include <cmath>
#include <limits>

#include "error.hpp"
#include "measures.hpp"
#include "mesh_transfer.hpp"
#include "mpi_comm.hpp"
#include "results.hpp"

namespace ltl {

std::string NestedStart::summary() const {
  return cat(
      "nested start from ", source, " (step ", source_step, ", load factor ", source_load_factor,
      ", ", source_cells, " cells): ", clamped_nodes, " node(s) and ", clamped_centroids,
      " cell centroid(s) outside the source mesh took the closest cell's value (at most ",
      max_outside, " m outside, ", max_outside_relative, " of that cell's size), ", seconds, " s");
}

NestedStart nested_start(const Solver& solver, const std::string& path, const std::string& key) {
  const auto t0 = std::chrono::steady_clock::now();
  const Discretization& disc = solver.discretization();
  const Problem& problem = solver.problem();
  const Mesh& mesh = problem.mesh;
  const int d = mesh.dim;
  const std::string where = cat(key, " ", path, ": ");
  StoredMesh source;
  std::optional<StoredStep> last;
  try {
    source = ResultsFile::read_mesh(path);
    last = ResultsFile::read_last_step(path);
  } catch (const Error& e) {
    throw Error(cat(key, ": cannot start from ", path, ": ", e.what()));
  }
  if (!last)
    throw Error(cat(where, "the file holds no completed step to start from (status: ",
                    ResultsFile::read_attribute(path, "status"), ")"));
  if (source.mesh.dim != d)
    throw Error(cat(where, "the file's mesh is ", source.mesh.dim, "-D, this problem's (",
                    mesh.source, ") is ", d, "-D"));
  NestedStart out;
  out.source = path;
  out.source_step = last->p;
  out.source_cells = source.mesh.num_cells();
  if (auto f = last->measures.find("load_factor"); f != last->measures.end())
    out.source_load_factor = f->second;
  const State& src = last->state;
  const Material& law = disc.split();
  const bool incompressible = law.incompressible();

  // u: the source field at the nodes; a node outside every source cell takes the closest cell's
  // value at the clamped reference point, refused when farther than kMaxOutside of its size.
  const PointLocator locate(source.mesh);
  State& s = out.state;
  s = solver.initial_state();
  s.u.setZero(mesh.num_nodes(), d);  // whole here, every node's row set below (then hold_rows)
  // Every node's position: the mesh's, or on a rank that has released it, gathered from the
  // ranks' ghost layers (X_at_nodes, collective) for the time of the nested start.
  IterateRows rows;
  const IterateRows* at = solver.state_rows(rows);
  Eigen::MatrixXd gathered;
  if (at && at->X) {
    std::vector<int> every(static_cast<std::size_t>(mesh.num_nodes()));
    for (int a = 0; a < mesh.num_nodes(); ++a) every[a] = a;
    gathered = X_at_nodes(mesh, every, at);
  }
  const Eigen::MatrixXd& X = at && at->X ? gathered : mesh.X;
  for (int a = 0; a < mesh.num_nodes(); ++a) {
    const Eigen::VectorXd x = X.row(a).transpose();
    const PointLocator::Hit hit = locate.locate(x);
    if (!hit.inside()) {
      ++out.clamped_nodes;
      out.max_outside = std::max(out.max_outside, hit.distance);
      out.max_outside_relative = std::max(out.max_outside_relative, hit.distance / hit.size);
      if (hit.distance > kMaxOutside * hit.size)
        throw Error(cat(where, "node ", a, " of ", mesh.source, " at (", x.transpose(), ") m is ",
                        hit.distance, " m outside the file's mesh (its closest cell ", hit.cell,
                        " is ", hit.size, " m across; at most ", kMaxOutside,
                        " of it is accepted): the two meshes are not of the same body, or not in "
                        "the same coordinates"));
    }
    s.u.row(a) = locate.evaluate(src.u, hit);
  }
  // The prescribed values where this problem prescribes them, at its step 1.
  const DirichletData& bc = disc.dirichlet();
  const double f1 = problem.ramp.factor(1, problem.time.dt);
  for (int i = 0; i < d; ++i) bc.impose(s.u, i, f1);

  // E = Fbar(u) (2.7), (3.3); lambda from the law at Fbar with the pressure of the source cell
  // that contains the cell's centroid (4.6).
  // A discretization of some cells (a rank's cells under mpirun, paper_notes/mpi.md) has the
  // mean gradients of its cells only: each rank computes its cells, on its rows of E and lambda
  // (the state between steps, Solver::initial_state; Discretization::cell_row).
  const std::vector<int>& held = disc.held_cells();
  Eigen::MatrixXd GU(static_cast<Eigen::Index>(d) * static_cast<Eigen::Index>(held.size()), d);
  mean_gradients(disc.cells(), 0, static_cast<int>(held.size()), s.u, GU);  // their rows
  for (int at = 0; at < static_cast<int>(held.size()); ++at) {
    const int e = held[at];
    Eigen::MatrixXd F = GU.block(d * at, 0, d, d).transpose();
    F.diagonal().array() += 1.0;
    double p = 0;
    if (incompressible) {
      const Mesh& part = disc.part();  // the held cells' nodes
      Eigen::VectorXd centroid = Eigen::VectorXd::Zero(d);
      for (int a = 0; a < part.nodes_per_cell(); ++a)
        centroid += part.X.row(part.cells(disc.part_row(e, at), a)).transpose();
      centroid /= part.nodes_per_cell();
      const PointLocator::Hit hit = locate.locate(centroid);
      out.clamped_centroids += !hit.inside();
      p = law.pressure(cell_tensor(src.E, hit.cell), cell_tensor(src.lambda, hit.cell));
    }
    const Eigen::Index row = disc.cell_row(s.E, e, at);
    s.E.block(row, 0, d, d) = F.transpose();
    s.lambda.block(row, 0, d, d) = law.multiplier(F, p).transpose();
  }
  if (disc.partial()) {
    double clamped = out.clamped_centroids;
    mpi::sum(&clamped, 1);
    out.clamped_centroids = static_cast<int>(clamped);
  }

  // Contact (4.7): e = ubar projected onto N . e <= g; lambda_c and beta from the nearest source
  // point of the same obstacle (by reference position).
  if (const ContactPoints* pts = disc.points()) {
    s.e = pts->mean * s.u;
    const int n_src = static_cast<int>(src.lambda_c.rows());
    const bool has_src = n_src > 0 && source.contact_centre.rows() == n_src;
    const bool same_obstacles =
        source.contact_obstacle.size() == n_src &&
        (n_src == 0 || source.contact_obstacle.maxCoeff() + 1 == disc.num_obstacles());
    for (int k = 0; k < disc.num_obstacles(); ++k) {
      const double kappa = problem.contacts[k].adhesion.kappa;
      const bool glued = problem.contacts[k].adhesion.glued();
      for (int q = pts->offset[k]; q < pts->offset[k + 1]; ++q) {
        const Eigen::RowVectorXd N = pts->normals.row(q);
        const double over = N.dot(s.e.row(q)) - pts->gap(q);
        if (over > 0) s.e.row(q) -= over * N;
        if (!has_src) continue;
        int best = -1;
        double best_d = std::numeric_limits<double>::infinity();
        for (int j = 0; j < n_src; ++j) {
          if (same_obstacles && source.contact_obstacle(j) != k) continue;
          const double dist =
              (source.contact_centre.row(j) - pts->centre.col(q).transpose()).norm();
          if (dist < best_d) best_d = dist, best = j;
        }
        if (best < 0) continue;
        const double b = src.beta.size() == n_src ? std::clamp(src.beta(best), 0.0, 1.0) : 0.0;
        if (glued) s.beta(q) = b;
        // The contact pressure of the source point, without the glue's force (Newton::unknowns).
        const Eigen::RowVectorXd lc = src.lambda_c.row(best) + kappa * b * b * src.e.row(best);
        const double pc = std::max(0.0, -lc.dot(N));
        s.lambda_c.row(q) = -pc * N - kappa * s.beta(q) * s.beta(q) * s.e.row(q);
      }
    }
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace ltl
