"""Side-by-side BSDF throughput: hairshade (f32, f64) beside Mitsuba 3's
`hair` on the same direction pairs, interleaved in one run so that the
ratios are meaningful on a shared, noisy machine.

    python benches/bench_bsdf.py [--n 1048576] [--csv out.csv]
"""

import sys

from hairshade.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
