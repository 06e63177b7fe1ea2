// Hertz contact of an elastic cylinder on a rigid plane: the verification of the Signorini solver
// of section 7 [LTL87 sec. 7, (7.1)-(7.10)], with both multiplier updates, Uzawa (4.3) and
// Bermudez-Moreno (7.7)-(7.10), on a sequence of refined meshes.
//
// Build:  cmake --build build -j2 --target hertz     (every experiments/*/*.cpp is a target)
// Run:    build/experiments/hertz [levels] [a_over_Rc] [rho_BM]
//         build/experiments/hertz                    4 meshes, a/Rc = 0.1, rho = 1 (about 1 min)
//         build/experiments/hertz 3 0.05             a smaller load: the Hertz model error / 4
//
// The problem (plane strain; by symmetry only x1 >= 0 of the lower half disc is computed):
//
//             P/(2 Rc) (uniform, downward)          find u (P2) minimizing
//            v  v  v  v  v  v  v                      1/2 a(u, u) - g.u              (7.1)
//            O ----------------- A                   with  u1 = 0 on x1 = 0 (symmetry)
//            |               .'                    and   ubar_s . N <= g_s  on each  (7.3)-(7.4)
//            |            .'     radius Rc               contact facet s,  N = (0, -1)
//            |         .'                          (frictionless unilateral contact with the
//            B . . .'                               plane x2 = -Rc, gap g_s at facet centres)
//     =======+========================== x2 = -Rc
//            |<- a ->|  contact zone
//
// Hertz (plane strain, total load P per unit length on the whole cylinder, E* = E / (1 - nu^2)):
//   a = sqrt(4 P Rc / (pi E*)),    p(x1) = p0 sqrt(1 - x1^2 / a^2),    p0 = 2 P / (pi a).
// Hertz is the limit a / Rc -> 0 (half-space, parabolic gap); for a finite a / Rc the exact
// discrete-free answer differs from it by O((a / Rc)^2) (about 0.2-0.3 % at a / Rc = 0.1,
// measured: paper_notes/section7.md). Why a traction on the flat face x2 = 0 of the half disc:
// the stresses near the contact depend only on the resultant P (Saint-Venant, a << Rc).
//
// Writes: three tables on stdout (accuracy against Hertz, self-convergence, cost of the two
// updates); nothing else. The numbers are quoted in paper_notes/section7.md.
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "error.hpp"
#include "mesh.hpp"
#include "results.hpp"
#include "signorini.hpp"

using namespace ltl;

namespace {

// ------------------------------------------------------------------------------------------------
// 1. Data. SI units. E and Rc set the scales; P is chosen from the target a / Rc.
struct Data {
  double Rc = 1.0;  // m
  double E = 1e9;   // Pa
  double nu = 0.3;
  double a_over_Rc = 0.1;
  double Es() const { return E / (1 - nu * nu); }
  // a^2 = 4 P Rc / (pi E*)  =>  P = pi E* a^2 / (4 Rc)   (N/m)
  double P() const { return M_PI * Es() * std::pow(a_over_Rc * Rc, 2) / (4 * Rc); }
  double a() const { return std::sqrt(4 * P() * Rc * (1 - nu * nu) / (M_PI * E)); }
  double p0() const { return 2 * P() / (M_PI * a()); }
  // Mesh: size hc = 0.2 a / 2^k within 1.5 a of the bottom point, 10 hc far away.
  double hc(int k) const { return 0.2 * a_over_Rc * Rc * std::pow(2.0, -k); }
};

// ------------------------------------------------------------------------------------------------
// 2. The mesh of refinement level k (gmsh, from the .geo: graded towards the bottom point B), and
// the Signorini problem on it.
Mesh mesh(const Data& d, int k) {
  const std::string geo = std::string(LTL_SOURCE_DIR) + "/experiments/hertz/half_cylinder.geo";
  return load_mesh(geo, {{"Rc", d.Rc},
                         {"k", k},
                         {"hc", 0.2 * d.a_over_Rc},
                         {"hf", 2 * d.a_over_Rc},
                         {"dc", 1.5 * d.a_over_Rc},
                         {"xc", std::min(0.9, 4 * d.a_over_Rc)}});
}

SignoriniProblem problem(const Data& d, const Mesh& m, int k, Update update, double rho) {
  SignoriniProblem pb;
  pb.mesh = m;
  pb.E = d.E;
  pb.nu = d.nu;
  DirichletCondition sym;  // u1 = 0 on x1 = 0
  sym.group = "symmetry_x";
  sym.components = {0};
  pb.dirichlet = {sym};
  Traction top;  // the half model carries P / 2 over the width Rc
  top.group = "top";
  top.g.value = Eigen::Vector3d(0, -d.P() / (2 * d.Rc), 0);
  pb.tractions = {top};
  pb.contact_group = "contact";
  pb.plane_point = Eigen::Vector3d(0, -d.Rc, 0);
  pb.plane_normal = Eigen::Vector3d(0, -1, 0);  // into the obstacle

  // 3. Algorithm. The rate of the iteration is set by R q_c against the contact stiffnesses of
  // the body, from E*/Rc (the whole body) to E*/hc (one facet): R q_c = 1.5 E* / sqrt(hc Rc),
  // about their geometric mean, came out best in a scan (paper_notes/section7.md).
  pb.algorithm.R = 1.0;
  pb.algorithm.q_c = 1.5 * d.Es() / std::sqrt(d.hc(k) * d.Rc);
  pb.algorithm.update = update;
  pb.algorithm.rho = rho;
  pb.algorithm.tol = 1e-9;
  pb.algorithm.max_iter = 20000;
  return pb;
}

// ------------------------------------------------------------------------------------------------
// 4. Measuring the contact zone: facet extents along x1, pressure, gap (lib: contact_zone()).
ContactZone measure(const SignoriniSolver& solver, const SignoriniSolution& sol) {
  const ContactPoints& F = solver.points();
  Eigen::VectorXd lo(F.size()), hi(F.size());
  for (int s = 0; s < F.size(); ++s) {
    lo(s) = std::min(F.vertices[0](0, s), F.vertices[1](0, s));
    hi(s) = std::max(F.vertices[0](0, s), F.vertices[1](0, s));
  }
  return contact_zone(lo, hi, sol.p, sol.gap, F.area);
}

struct Row {
  int k = 0, cells = 0, facets = 0, dofs = 0;
  ContactZone zone;
  double h = 0;             // facet length at the edge of contact
  int it[2] = {0, 0};       // Uzawa, Bermudez-Moreno
  double time[2] = {0, 0};  // s, iterations only
  bool converged[2] = {false, false};
  double factorize = 0;   // s
  double du = 0, dp = 0;  // max |u_UZ - u_BM| / max |u|, max |p_UZ - p_BM| / p0
};

// The history and the contact fields of one run, in the results-file layout of lib/results.hpp
// (no cell unknowns: the Signorini problem has neither E nor lambda, nor beta).
void write(const SignoriniSolver& solver, const SignoriniSolution& sol, const Data& d,
           const std::string& dir, bool uzawa) {
  const SignoriniProblem& pb = solver.problem();
  const Eigen::VectorXd N = solver.normal();
  State s;
  s.u = sol.u;
  s.e = sol.H * N.transpose();  // #points x dim, like u
  s.lambda_c = sol.lambda_c * N.transpose();
  StepData step;
  step.p = 1;
  step.t = 0;
  step.state = &s;
  step.report = &sol.report;
  step.fields["contact_pressure"] = sol.p;
  step.fields["gap"] = sol.gap;
  RunInfo info;
  info.name = "signorini";
  info.config_text =
      cat("Hertz half cylinder [LTL87 sec. 7]: Rc = ", d.Rc, " m, E = ", d.E, " Pa, nu = ", d.nu,
          ", P = ", d.P(), " N/m, update = ", uzawa ? "uzawa" : "bermudez-moreno",
          ", rho = ", pb.algorithm.rho);
  info.attributes = library_versions();
  std::filesystem::create_directories(dir);
  ResultsOptions options;
  options.contact.facets = &pb.mesh.boundary(pb.contact_group);
  options.contact.centre = solver.points().centre;
  options.contact.area = solver.points().area;
  ResultsFile f =
      ResultsFile::create(dir + (uzawa ? "/signorini-uzawa.h5" : "/signorini-bermudez-moreno.h5"),
                          pb.mesh, info, options);
  f.append(step);
  f.set_status(sol.report.converged ? "complete" : "diverged: " + sol.report.status);
}

double order(double e_coarse, double e_fine, double ratio) {
  return std::log(std::abs(e_coarse) / std::abs(e_fine)) / std::log(ratio);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && (std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help")) {
    std::printf("usage: hertz [levels >= 1] [0 < a_over_Rc < 0.5] [1/2 < rho_BM <= 1] [OUTDIR]\n");
    return 0;
  }
  for (int i = 1; i < argc; ++i)  // no option but --help: an unknown one is a usage error
    if (argv[i][0] == '-' && !std::isdigit(static_cast<unsigned char>(argv[i][1])) &&
        argv[i][1] != '.') {
      std::fprintf(stderr,
                   "hertz: unknown option '%s'\nusage: hertz [levels >= 1] [0 < a_over_Rc < "
                   "0.5] [1/2 < rho_BM <= 1] [OUTDIR]\n",
                   argv[i]);
      return 2;
    }
  try {
    Data d;
    const int levels = argc > 1 ? std::atoi(argv[1]) : 4;
    if (argc > 2) d.a_over_Rc = std::atof(argv[2]);
    const double rho_bm = argc > 3 ? std::atof(argv[3]) : 1.0;
    // Optional: a folder where the finest level's runs are written as results files
    // (signorini-uzawa.h5, signorini-bermudez-moreno.h5) for `make compare`.
    const std::string out = argc > 4 ? argv[4] : "";
    if (levels < 1 || !(d.a_over_Rc > 0 && d.a_over_Rc < 0.5))
      throw Error("usage: hertz [levels >= 1] [0 < a_over_Rc < 0.5] [1/2 < rho_BM <= 1] [OUTDIR]");
    std::printf("Hertz verification of the Signorini solver [LTL87 sec. 7]\n");
    std::printf("  Rc = %g m, E = %g Pa, nu = %g, P = %.6g N/m (a/Rc = %g)\n", d.Rc, d.E, d.nu,
                d.P(), d.a_over_Rc);
    std::printf(
        "  Hertz: a = %.6g m, p0 = %.6g Pa; updates: Uzawa (4.3) rho = 1, "
        "Bermudez-Moreno (7.7)-(7.10) rho = %g; tol = 1e-9\n\n",
        d.a(), d.p0(), rho_bm);

    // 5. The refinement loop: one factorization per mesh and update, both updates from the same
    // start H = min(g, 0), lambda_c = 0.
    std::vector<Row> rows;
    for (int k = 0; k < levels; ++k) {
      Row row;
      row.k = k;
      SignoriniSolution sols[2];
      const Mesh m = mesh(d, k);
      for (int u = 0; u < 2; ++u) {
        const Update update = u == 0 ? Update::Uzawa : Update::BermudezMoreno;
        SignoriniSolver solver(problem(d, m, k, update, u == 0 ? 1.0 : rho_bm));
        sols[u] = solver.solve();
        const StepReport& rep = sols[u].report;
        if (!out.empty() && k == levels - 1) write(solver, sols[u], d, out, u == 0);
        row.it[u] = rep.iterations;
        row.time[u] = rep.history.back().wall;
        row.converged[u] = rep.converged;
        if (!rep.converged)
          std::printf("  level %d, %s: %s\n", k, u == 0 ? "Uzawa" : "Bermudez-Moreno",
                      rep.status.c_str());
        if (u == 0) {
          row.cells = solver.problem().mesh.num_cells();
          row.facets = solver.points().size();
          row.dofs = solver.num_free_dofs();
          row.factorize = solver.factorize_seconds();
          row.zone = measure(solver, sols[0]);
          const ContactPoints& F = solver.points();
          for (int s = 0; s < F.size(); ++s)
            if (std::abs(F.centre(0, s) - d.a()) < 2 * d.hc(k)) row.h = std::max(row.h, F.area(s));
        }
      }
      row.du = (sols[0].u - sols[1].u).cwiseAbs().maxCoeff() / sols[0].u.cwiseAbs().maxCoeff();
      row.dp = (sols[0].p - sols[1].p).cwiseAbs().maxCoeff() / d.p0();
      rows.push_back(row);
      std::fflush(stdout);
    }

    // 6. Accuracy against Hertz. a_h: edge interpolated from the gaps of the first free facets;
    // a_m: second moment of p (exact for Hertz's ellipse); p0_h: p extrapolated to x1 = 0.
    // Orders: log2 of the ratio of successive errors (every level halves the mesh size).
    std::printf("Accuracy against Hertz (err = computed / Hertz - 1; ord = observed order)\n");
    std::printf("%5s %7s %6s %6s %6s | %9s %9s %5s | %9s %9s %5s | %11s %9s %5s | %9s\n", "level",
                "cells", "facets", "active", "h/a", "a_h/Rc", "err", "ord", "a_m/Rc", "err", "ord",
                "p0_h (Pa)", "err", "ord", "force err");
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      const double ea = r.zone.half_width / d.a() - 1, em = r.zone.half_width_moment / d.a() - 1,
                   ep = r.zone.peak / d.p0() - 1;
      auto ord = [&](auto get, double e) {
        if (i == 0) return std::string("   - ");
        char b[16];
        std::snprintf(b, sizeof b, "%5.2f", order(get(rows[i - 1]), e, 2.0));
        return std::string(b);
      };
      std::printf(
          "%5d %7d %6d %6d %6.3f | %9.6f %9.2e %s | %9.6f %9.2e %s | %11.6g %9.2e %s | %9.1e\n",
          r.k, r.cells, r.facets, r.zone.active, r.h / d.a(), r.zone.half_width / d.Rc, ea,
          ord([&](const Row& q) { return q.zone.half_width / d.a() - 1; }, ea).c_str(),
          r.zone.half_width_moment / d.Rc, em,
          ord([&](const Row& q) { return q.zone.half_width_moment / d.a() - 1; }, em).c_str(),
          r.zone.peak, ep, ord([&](const Row& q) { return q.zone.peak / d.p0() - 1; }, ep).c_str(),
          r.zone.force / (d.P() / 2) - 1);
    }

    // 7. Self-convergence: the order from three successive meshes, independent of Hertz, and the
    // Richardson limit q_inf = q_k + (q_k - q_{k-1}) / (2^ord - 1) compared with Hertz (what is
    // left is the model error of Hertz at this a/Rc, not a discretization error).
    if (rows.size() >= 3) {
      std::printf("\nSelf-convergence (ord from levels k-2, k-1, k; lim = Richardson limit)\n");
      std::printf("%5s | %7s %10s | %7s %10s | %7s %10s\n", "level", "ord a_h", "lim/a - 1",
                  "ord a_m", "lim/a - 1", "ord p0", "lim/p0 - 1");
      for (std::size_t i = 2; i < rows.size(); ++i) {
        auto self = [&](auto get, double ref, double& lim) {
          const double q0 = get(rows[i - 2]), q1 = get(rows[i - 1]), q2 = get(rows[i]);
          const double o = order(q1 - q0, q2 - q1, 2.0);
          lim = q2 + (q2 - q1) / (std::pow(2.0, o) - 1) - ref;
          return o;
        };
        double la, lm, lp;
        const double oa = self([](const Row& q) { return q.zone.half_width; }, d.a(), la);
        const double om = self([](const Row& q) { return q.zone.half_width_moment; }, d.a(), lm);
        const double op = self([](const Row& q) { return q.zone.peak; }, d.p0(), lp);
        std::printf("%5zu | %7.2f %10.2e | %7.2f %10.2e | %7.2f %10.2e\n", i, oa, la / d.a(), om,
                    lm / d.a(), op, lp / d.p0());
      }
    }

    // 8. Cost: iterations to r_G + r_B < tol and wall time of the iterations (the factorization,
    // done once per solver, is listed apart), and the agreement of the two fixed points.
    std::printf("\nCost of the two updates (time: iterations only; factorization apart)\n");
    std::printf("%5s %8s %9s | %8s %9s | %8s %9s | %10s %10s\n", "level", "dofs", "factor s",
                "UZ it", "UZ s", "BM it", "BM s", "|du|/|u|", "|dp|/p0");
    for (const Row& r : rows)
      std::printf("%5d %8d %9.3f | %7d%s %9.3f | %7d%s %9.3f | %10.1e %10.1e\n", r.k, r.dofs,
                  r.factorize, r.it[0], r.converged[0] ? " " : "*", r.time[0], r.it[1],
                  r.converged[1] ? " " : "*", r.time[1], r.du, r.dp);
    std::printf("(* = not converged)\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hertz: %s\n", e.what());
    return 1;
  }
}
