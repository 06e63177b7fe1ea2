//          LTL87 Figures 5 and 6 under mesh refinement: the numbers `make verify` compares
//
// Paper:    Le Tallec & Lotfi (1987), section 8. The paper gives one mesh per figure (Fig 5: 120
//           Ruas elements for half the cylinder; Fig 6: 270 H8 for a quarter of the gutter). This
//           driver asks how far their numbers are from the mesh-converged ones, and whether they
//           converge to the independent Newton solver's (experiments/peer/peer.py).
//
// Build:    cmake --build build --target refinement
// Run:      build/experiments/refinement fig5 [levels=7,14,28,56] [json=FILE] [key=value]...
//           build/experiments/refinement fig6 [levels=1,2] [json=FILE] [key=value]...
//           (from the repository root; every key=value is a configuration override applied to
//           every mesh after the driver's own, e.g. algorithm.tol=1e-10)
//
// Problem:  the figure exactly as experiments/figN/figN.toml states it; only the mesh changes.
//   fig5:  half_disc.geo with n = nd = K edges on each quarter circle and on each half of the
//          symmetry axis (K = 7 is the paper's size, 122 P2 triangles), and R = 20 instead of
//          the configuration's R = 5 (with R = 5 the iteration does not converge beyond K = 7;
//          R changes the path, not the fixed point [LTL87 sec. 3]).
//   fig6:  gutter.geo with (nt, na, nl) = L x (2, 9, 15) hexahedra through the thickness,
//          around the quarter arc and along the half length (L = 1 is the paper's 270 H8).
//
//                     x2                                   Fig 6 cross-section
//                     |   * reference node (0, 1)              --------+--------
//                  .--*--.                                     \       |       /
//                /    |    \        f = (0, -400) kN/m^3        '------+------'
//               |     O-----|--> x1                                    |  sag
//                \    |    /                                           v
//                  '--+--'                                  ///////////+///////// x2 = -3
//          ///////////+<-a->//////  x2 = -1
//
// Prints:   one row per mesh: cells, contact points, iterations, wall time, the observables
//           (fig5: drop of the top node, contact half-width a by two definitions, peak nodal
//           contact pressure; fig6: largest sag, contact force / load, contact area, peak
//           pressure), penetration, the equilibrium measure; then, per observable, the
//           differences between successive meshes and the observed order log2(ratio).
//           json=FILE writes the same rows for figures/verify.py. Exit 0 when every mesh
//           converged, 1 otherwise.

#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <string>
#include <vector>

#include "alg2.hpp"
#include "config.hpp"
#include "error.hpp"
#include "measures.hpp"

namespace {

// 1. The numbers reported for one mesh. Definitions in lib/measures.hpp.
struct Row {
  int level = 0, cells = 0, nodes = 0, points = 0, in_contact = 0, iterations = 0;
  bool converged = false;
  std::string status;
  double seconds = 0;
  double drop = NAN;         // fig5: -u2 at the node (0, 1); fig6: max over nodes of -u2
  double a_edge = NAN;       // fig5: deformed x1 of the outermost contact node in contact
  double a_moment = NAN;     // fig5: 2 sqrt(M2 / M0) of the contact force distribution
  double p_max = NAN;        // peak nodal contact pressure (nominal, Pa)
  double force_ratio = NAN;  // contact force / applied load
  double area = NAN;         // reference area (length in 2-D) of the points in contact
  double penetration = NAN;  // max over contact-surface nodes of (x - p0) . N, > 0 inside
  double residual = NAN;     // equilibrium measure: max nodal force residual / max nodal load
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Row run(const std::string& figure, int level, const std::vector<std::string>& extra) {
  Row row;
  row.level = level;
  const auto t0 = std::chrono::steady_clock::now();

  // 2. The configuration of the figure on the level-`level` mesh.
  std::vector<std::string> overrides;
  if (figure == "fig5") {
    overrides = {"mesh.parameters.n=" + std::to_string(level),
                 "mesh.parameters.nd=" + std::to_string(level), "algorithm.R=20"};
  } else {
    overrides = {"mesh.parameters.nt=" + std::to_string(2 * level),
                 "mesh.parameters.na=" + std::to_string(9 * level),
                 "mesh.parameters.nl=" + std::to_string(15 * level)};
  }
  overrides.insert(overrides.end(), extra.begin(), extra.end());
  const std::string config = "experiments/" + figure + "/" + figure + ".toml";
  const ltl::Problem problem = ltl::load_problem(config, overrides);
  const ltl::Mesh& mesh = problem.mesh;
  row.cells = mesh.num_cells();
  row.nodes = mesh.num_nodes();

  // 3. One step of ALG2 (4.1)-(4.4) from the rest state, to the configured tolerance.
  ltl::Solver solver(problem);
  ltl::State s = solver.initial_state();
  const ltl::StepReport report = solver.solve_step(s, s.beta);
  row.seconds = seconds_since(t0);  // mesh generation + factorization + iterations
  row.converged = report.converged;
  row.status = report.status;
  row.iterations = report.iterations;
  row.residual = report.force_residual;

  // 4. The observables (lib/measures.hpp), the contact quantities along x1.
  const ltl::ContactMeasures m = ltl::contact_measures(solver.discretization(), s, 0);
  row.points = m.points;
  row.in_contact = m.in_contact;
  row.p_max = m.p_max;
  row.a_edge = m.a_edge;
  row.a_moment = m.a_moment;
  row.area = m.area;
  row.penetration = m.penetration;
  // The load carried by the plane: the body force (fig5) or the tractions (fig6), along N.
  row.force_ratio = m.force / ltl::load_along_normal(solver.problem(), solver.external_load());
  row.drop = figure == "fig5" ? -s.u(ltl::node_at(mesh, Eigen::Vector2d(0, 1)), 1)
                              : (-s.u.col(1)).maxCoeff();
  return row;
}

// 5. Observed convergence of one quantity: differences between successive meshes, their
//    ratios, and the order log2(ratio) (the mesh size halves from one row to the next).
void convergence(const char* name, const std::vector<Row>& rows, double Row::*q) {
  std::printf("  %-22s", name);
  for (const Row& r : rows) std::printf(" %11.6g", r.*q);
  std::printf("\n  %-22s", "  differences");
  std::vector<double> d;
  for (size_t i = 1; i < rows.size(); ++i) {
    d.push_back(rows[i].*q - rows[i - 1].*q);
    std::printf(" %11.3e", d.back());
  }
  std::printf("\n  %-22s", "  ratio (order)");
  for (size_t i = 1; i < d.size(); ++i) {
    const double ratio = d[i - 1] / d[i];
    std::printf("  %6.2f (%4.2f)", ratio, std::log2(std::abs(ratio)));
  }
  std::printf("\n");
}

// 6. The rows as JSON (one object per mesh), read by figures/verify.py.
void write_json(const std::string& path, const std::string& figure, const std::vector<Row>& rows) {
  std::ofstream out(path);
  if (!out) throw ltl::Error(ltl::cat(path, ": cannot write"));
  out.precision(12);
  out << "{\"figure\": \"" << figure << "\", \"code\": \"ltl\", \"runs\": [\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    auto num = [&](const char* k, double v) {
      out << ", \"" << k << "\": ";
      if (std::isfinite(v))
        out << v;
      else
        out << "null";
    };
    out << " {\"level\": " << r.level << ", \"cells\": " << r.cells << ", \"nodes\": " << r.nodes
        << ", \"iterations\": " << r.iterations
        << ", \"converged\": " << (r.converged ? "true" : "false");
    num("time_s", r.seconds);
    num("drop", r.drop);
    num("a_edge", r.a_edge);
    num("a_moment", r.a_moment);
    num("p_max", r.p_max);
    num("force_ratio", r.force_ratio);
    num("contact_area", r.area);
    num("penetration", r.penetration);
    num("force_residual", r.residual);
    out << "}" << (i + 1 < rows.size() ? "," : "") << "\n";
  }
  out << "]}\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || (std::string(argv[1]) != "fig5" && std::string(argv[1]) != "fig6")) {
    const bool help =
        argc == 2 && (std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help");
    std::fprintf(help ? stdout : stderr,
                 "usage: %s fig5|fig6 [levels=L1,L2,...] [json=FILE] [key=value]...\n"
                 "(run from the repository root)\n",
                 argv[0]);
    return help ? 0 : 2;
  }
  const std::string figure = argv[1];
  std::vector<std::string> extra;
  std::vector<int> levels =
      figure == "fig5" ? std::vector<int>{7, 14, 28, 56} : std::vector<int>{1, 2};
  std::string json;
  try {
    for (int i = 2; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg.rfind("levels=", 0) == 0) {
        levels.clear();
        for (size_t k = 7; k < arg.size();) {
          size_t j = arg.find(',', k);
          if (j == std::string::npos) j = arg.size();
          levels.push_back(std::stoi(arg.substr(k, j - k)));
          if (levels.back() < 1) throw ltl::Error(ltl::cat("'", arg, "': levels must be >= 1"));
          k = j + 1;
        }
      } else if (arg.rfind("json=", 0) == 0) {
        json = arg.substr(5);
      } else if (arg.find('=') != std::string::npos) {
        extra.push_back(arg);
      } else {
        throw ltl::Error(ltl::cat("unexpected argument '", arg, "' (expected key=value)"));
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "refinement: error: %s\n", e.what());
    return 2;
  }

  std::vector<Row> rows;
  bool all_converged = true;
  try {
    std::printf("%s under refinement (experiments/%s/%s.toml%s)\n\n", figure.c_str(),
                figure.c_str(), figure.c_str(), figure == "fig5" ? ", R = 20" : "");
    std::printf("%5s %6s %6s %6s %6s %8s %9s %9s %9s %8s %11s %9s %9s %9s %s\n", "level", "cells",
                "nodes", "points", "iters", "time s", "contact", "a_edge m", "a_mom m",
                figure == "fig5" ? "drop m" : "sag m", "p_max Pa", "F/load", "pen. m", "residual",
                "status");
    for (int level : levels) {
      const Row r = run(figure, level, extra);
      all_converged &= r.converged;
      std::printf(
          "%5d %6d %6d %6d %6d %8.2f %5d/%-3d %9.5f %9.5f %8.5f %11.5g %9.6f %9.2e %9.2e %s\n",
          r.level, r.cells, r.nodes, r.points, r.iterations, r.seconds, r.in_contact, r.points,
          r.a_edge, r.a_moment, r.drop, r.p_max, r.force_ratio, r.penetration, r.residual,
          r.status.c_str());
      std::fflush(stdout);
      rows.push_back(r);
      if (!json.empty()) write_json(json, figure, rows);  // keep what is done
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "refinement: error: %s\n", e.what());
    return 1;
  }

  std::printf("\nObserved convergence (h halves from column to column):\n");
  if (figure == "fig5") {
    convergence("drop of the top (m)", rows, &Row::drop);
    convergence("a_moment (m)", rows, &Row::a_moment);
    convergence("a_edge (m)", rows, &Row::a_edge);
  } else {
    convergence("sag (m)", rows, &Row::drop);
    convergence("contact force / load", rows, &Row::force_ratio);
    convergence("contact area (m^2)", rows, &Row::area);
  }
  convergence("peak pressure (Pa)", rows, &Row::p_max);
  convergence("nodal penetration (m)", rows, &Row::penetration);
  if (!all_converged) std::printf("\nWARNING: some meshes did not converge (see status)\n");
  return all_converged ? 0 : 1;
}
