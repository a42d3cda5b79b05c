#!/usr/bin/env python3
"""Trims fuzz/corpus/TARGET to a small set that keeps most of its coverage (fuzz/README.md).

`cargo fuzz cmin` keeps every input that adds a libFuzzer feature, hit counts included, which
leaves megabytes. This keeps the coverage edges instead, within a byte budget: it has the built
target (`cargo +nightly fuzz build -O TARGET` first) list each input's edges in a merge control
file, then takes inputs greedily by new edges per byte until no input adds an edge or fits.

    python3 fuzz/trim_corpus.py TARGET MAX_LEN BUDGET_BYTES
"""

import os
import subprocess
import sys
import tempfile

target, max_len, budget = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
fuzz = os.path.dirname(os.path.abspath(__file__))
corpus = os.path.join(fuzz, "corpus", target)
binary = os.path.join(fuzz, "target", "x86_64-unknown-linux-gnu", "release", target)

with tempfile.TemporaryDirectory() as tmp:
    control = os.path.join(tmp, "control")
    os.mkdir(os.path.join(tmp, "out"))
    subprocess.run(
        [binary, "-merge=1", f"-max_len={max_len}", f"-merge_control_file={control}",
         os.path.join(tmp, "out"), corpus],
        check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        env=dict(os.environ, ASAN_OPTIONS="detect_odr_violation=0"))
    # Control file: the input count, the count in the first directory, the paths, then per input
    # "STARTED i size", "FT i features...", "COV i edges...".
    lines = open(control, encoding="latin-1").read().split("\n")
    paths = lines[2:2 + int(lines[0])]
    edges = {}
    for line in lines[2 + len(paths):]:
        if line.startswith("COV "):
            i, *cov = map(int, line.split()[1:])
            edges[i] = set(cov)

size = {i: os.path.getsize(paths[i]) for i in edges}
covered, kept, total = set(), set(), 0
while True:
    fits = [i for i in edges if i not in kept and total + size[i] <= budget and edges[i] - covered]
    if not fits:
        break
    # 64 bytes more per input, so that the tiniest inputs do not win on size alone.
    best = max(fits, key=lambda i: (len(edges[i] - covered) / (size[i] + 64), -size[i]))
    kept.add(best)
    covered |= edges[best]
    total += size[best]

for i, path in enumerate(paths):
    if i not in kept:
        os.remove(path)
all_edges = set().union(*edges.values())
print(f"{target}: kept {len(kept)} of {len(paths)} inputs, {total} bytes, "
      f"{len(covered)} of {len(all_edges)} edges")
