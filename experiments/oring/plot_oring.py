"""The figure of experiments/oring: figures/obstacles.py on its results file (the half ring
mirrored to the whole).

    /usr/bin/python3 experiments/oring/plot_oring.py results/oring.h5 results/oring.png
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "figures"))

import obstacles  # noqa: E402

if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    obstacles.main(sys.argv[1], sys.argv[2], mirror=True)
