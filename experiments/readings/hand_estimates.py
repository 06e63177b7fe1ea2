#!/usr/bin/python3
"""Hand estimates of the peel of Figs 3 and 4 (paper_notes/readings.md), checked against the
runs of the readings study (results files only).

    /usr/bin/python3 experiments/readings/hand_estimates.py [results/readings]

1. Glue strength. Per unit area the glue stores (kappa/2) beta^2 |e|^2 and holds w beta
   [LTL87 (1.3)]; d/dbeta at beta = 1 is kappa |e|^2 - w, so the glue starts to break where
   |e| > sqrt(w / kappa), i.e. where its traction kappa |e| exceeds sqrt(w kappa).
2. A debonded flap of length a under the dead pull q(x) = q0 (1 - x) is a cantilever clamped at
   the front: M(a) = q0 (a^2/2 - a^3/6), and the energy released per unit debonded length is
   G = M^2 / (2 E' I), E' the plane-strain modulus, I = H^3/12. G grows like a^4: once G > w
   the front has no glued equilibrium to stop at; only the viscous delay holds it.
3. Viscous delay. The facet problem (6.1) with the kernel weight k_ss of the facet itself
   ((6.4)-(6.5); the other facets are 1/d0 = 1 mm away from a 36 mm facet, weight e^-36) is
   stationary in beta when  k_ss (beta_prev - beta) / dt = kappa beta |e|^2 - w,  so a facet
   loses its glue in about  t_d = k_ss / (kappa beta |e|^2 - w).  Centre-point rule (6.4):
   k_ss = d0 |G_s|; exact integral: k_ss = 2 - 2 (1 - exp(-d0 h)) / (d0 h).
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../figures"))
import ltl_results as lr  # noqa: E402


def main(directory):
    w, kappa, d0, q0 = 0.01, 1e9, 1000.0, 1e4
    print("1. glue strength sqrt(w kappa) = %.4g Pa; critical opening sqrt(w/kappa) = %.4g m"
          % (np.sqrt(w * kappa), np.sqrt(w / kappa)))
    bars = {"fig3": ("compressible, E = 1000 kPa, nu = 0.33", 0.2, 1e6 / (1 - 0.33 ** 2)),
            "fig4": ("incompressible, mu = 2 C1 = 375 kPa", 0.05, 4 * 375e3)}
    for bar, (text, H, Ep) in bars.items():
        EI = Ep * H ** 3 / 12
        M = lambda a: q0 * (a * a / 2 - a ** 3 / 6)  # noqa: E731
        G = lambda a: M(a) ** 2 / (2 * EI)  # noqa: E731
        a = np.linspace(1e-4, 0.5, 200001)
        a_c = a[np.argmax(G(a) > w)]
        h = 1 / 28
        print("2. %s (%s, H = %g m): E'I = %.4g N m; critical flap a_c = %.4g m (G = w); "
              "G(h = 1/28) = %.3g J/m^2 = %.3g w; G(0.1 m) = %.3g J/m^2" %
              (bar, text, H, EI, a_c, G(h), G(h) / w, G(0.1)))
    for label, kss in (("centre-point (6.4)", d0 / 28),
                       ("exact", 2 - 2 * (1 - np.exp(-d0 / 28)) / (d0 / 28))):
        print("3. k_ss, %s rule, 28 facets: %.4g J s/m^2" % (label, kss))
    # Against the runs: R1 (pulled up), centre-point kernel, q_c = 3e7.
    for bar in ("fig3", "fig4"):
        path = os.path.join(directory, "%s_R1_centre_qc3e7.h5" % bar)
        if not os.path.exists(path):
            print("(%s missing)" % path)
            continue
        r = lr.load(path, fields=["beta", "e", "lambda_c"])
        xc = r.mesh.contact_centre[:, 0]
        area = r.mesh.contact_area
        s = int(np.argmin(xc))
        kss = d0 * area[s]
        dt = r.steps[0].t
        s1 = r.steps[0]
        e = s1.fields["e"]
        trac = kappa * np.linalg.norm(e, axis=1)
        broken = xc[s1.fields["beta"] < 1 - 1e-9]
        print("%s R1 step 1: glue traction kappa |e| at the first facet %.4g Pa; facets with "
              "beta < 1 reach x1 = %.3f m, traction there %.4g Pa, at the next facet %.4g Pa" %
              (bar, trac[s], broken.max(), trac[xc == broken.max()][0],
               trac[np.argmin(np.where(xc > broken.max(), xc, 9))]))
        beta_prev = 1.0
        print("   step  t  beta1  driving kappa beta|e|^2 - w [J/m^2]  dbeta run  dbeta (6.1) "
              " t_d = k_ss/driving [s]")
        for st in r.steps[:8]:
            b = st.fields["beta"][s]
            drive = kappa * b * np.sum(st.fields["e"][s] ** 2) - w
            print("   %3d %4g  %.4f  %.4g  %.4g  %.4g  %.4g" %
                  (st.p, st.t, b, drive, beta_prev - b, dt * drive / kss, kss / drive))
            beta_prev = b
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "results/readings"))
