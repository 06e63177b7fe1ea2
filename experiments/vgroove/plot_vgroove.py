"""The figure of experiments/vgroove: figures/obstacles.py on its results file.

    /usr/bin/python3 experiments/vgroove/plot_vgroove.py results/vgroove.h5 results/vgroove.png
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "figures"))

import obstacles  # noqa: E402

if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    obstacles.main(sys.argv[1], sys.argv[2], mirror=False)
