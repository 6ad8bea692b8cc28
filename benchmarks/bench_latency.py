"""Latency at slice time (issue 17): ``loadpath run`` beside PrusaSlicer 2.5 slicing the same part.

Usage::

    python benchmarks/bench_latency.py [OUT_DIR] [--repeats 3] [--quick] [--engine NAME]

(``./dev bench`` passes the same arguments to every benchmark; unknown ones are ignored.)

Both programs are timed as whole processes (interpreter start included), median of ``--repeats``,
in the same run, so the ratio holds on a loaded machine.  Parts (PrusaSlicer 2.5, MK3S presets,
``tests/slicing.py``; load case ``tests/cases.py`` ``GRIP_PULL``: clamped at x_min, pulled at x_max):

``example``
    the shipped example (``examples/ohs.gcode``, 10 layers); PrusaSlicer re-slices its STL.
``specimen-100``
    the specimen's outline 20 mm thick, 100 layers, the example's settings.
``gusset-gyroid30``, ``gusset-gyroid30-sparse``
    a shelf gusset (right triangle, 60 mm legs, two 5 mm bolt holes, 8 mm thick: 40 layers) at 30 %
    gyroid, 3 top / 3 bottom layers: the default replace set (internal solid), then
    ``--replace solid,sparse`` (gyroid makes every sparse layer distinct).
``gusset-100``
    the same part at 100 % (rectilinear): a solid part.
``specimen-1000`` (not with ``--quick``)
    the specimen's outline 200 mm tall: 1000 layers, 23 MB.

Columns: PrusaSlicer's slicing time; ``loadpath run`` on a cold cache (``first``, each repeat with
its own empty ``LOADPATH_CACHE_DIR``); ``repeat``: the part re-sliced with other speeds and
temperatures (same geometry, same load case) and run against the cache one first run filled (repeat
k against first run k's: before 2026-12-04, every repeat used the first run's cache, so repeats 2 and
3 re-ran a file the cache had seen whole, and the median hid the first re-export's cost); each
with its ratio to the slicing time; the largest peak resident memory of any loadpath run (``wait4``);
the input's size and the output's against it (``out/in``, first run).  Targets of issue 17 are
printed under the table with the measured figure and met/missed.  ``--quick``: one repeat, the
example, the 100-layer specimen and the default gyroid gusset only.  ``OUT_DIR/bench_latency.json``
keeps the rows when a folder is given.  ``cpu:sl``, ``first``, ``repeat``: CPU seconds (user + system,
``RUSAGE_CHILDREN``) of the slicer and of the two runs: on a machine shared with other jobs the wall
times are mostly waiting, the CPU seconds are what each program did (a first run's engine workers
live under a forkserver and may be left out: a lower bound).  The children may write bytecode, as an
installed loadpath has it.

Measured 2026-12-01 on the 2-core development machine shared with about eight other jobs (load
average 7 for BEFORE, 17-24 for AFTER: every time is several times its idle value, and the
slicer's times vary 2-5x between runs; compare the ratios, and those loosely).  BEFORE = commit
d5ef910 (no cache, bead runs 5 % / 10 %), AFTER = 6b3a5a9 (cache, lazy imports, 15 % / 40 %),
median of 3 (the 1000-layer file: 1 run)::

    part                     slice s  first s     x  repeat s     x  peak MB  out/in
    BEFORE
    example                     1.09    17.23  15.8     17.93  16.4      259    4.00
    specimen-100                3.34    62.77  18.8    146.00  43.6      412    4.89
    gusset-gyroid30            11.44    83.32   7.3     50.05   4.4      309    1.13
    gusset-gyroid30-sparse      5.95   120.70  20.3    110.70  18.6      288    0.56
    gusset-100                  7.32   121.83  16.6    102.22  14.0      327    6.86
    specimen-1000              (loadpath run killed after 900 s)
    AFTER
    example                     5.31    98.56  18.6     28.87   5.4      251    2.33
    specimen-100               14.24   192.55  13.5     78.41   5.5      359    2.74
    gusset-gyroid30             5.19    57.66  11.1     51.40   9.9      305    1.06
    gusset-gyroid30-sparse     13.74   198.37  14.4     59.23   4.3      278    0.39
    gusset-100                  7.33    78.85  10.8     37.91   5.2      296    3.93
    specimen-1000              74.91  1251.44  16.7    358.27   4.8     1321    2.78

Measured 2026-12-02 (issue 17, second pass: the verdict's predictions, the linked runs and each
layer's bead neighbours in the cache; a cached run loads no scipy; the bead neighbour search on
per-layer columns with segment reductions, reusing identical layers).  ``--quick --only
example,gusset-gyroid30``, one run each, BEFORE = 4220ea9 and AFTER = this branch run side by side
(load average 12-16 on the 2 cores: the slicer's 0.3 s of CPU took 4 s of wall)::

    part                     slice s  first s     x  repeat s     x  peak MB  out/in  cpu:sl  first  repeat
    BEFORE
    example                     4.00   245.24  61.3    217.17  54.3      404    3.60     0.3   17.5    14.8
    gusset-gyroid30            12.38   140.92  11.4     92.94   7.5      372    1.08     1.3   20.4    16.6
    AFTER
    example                     4.20   231.29  55.1     39.55   9.4      412    3.60     0.3   16.9     2.6
    gusset-gyroid30            13.75   216.51  15.7     66.95   4.9      367    1.08     1.3   19.1     7.6

The repeated run's CPU: 14.8 -> 2.6 s on the example (its beads are the same: both predictions and
every link come from the cache; 2.2 s once the simplified engine paths are kept too, commit 6df682c,
``/usr/bin/time`` at load 8-10), 16.6 -> 7.6 s on the gusset (PrusaSlicer's gyroid moves at the other
speeds, so both predictions are made again, from the kept neighbours of the layers that did not
change).  Outputs byte-identical to BEFORE's (without the verdict's date) and the same verdict figures
on the example, a fresh PrusaSlicer slice of it, its re-slice with other speeds and the gusset.  The
100-layer specimen's first run was killed after 900 s at this load, BEFORE and AFTER alike: not
measured; nor the 1000-layer file.

Where a repeated run still goes (2026-12-01, 100-layer specimen, in process, from the cache, load
19, before the 15 % / 40 % bead runs halved its output lines):
parse 2.1 s, geometry 12.3 s, loadcase 4.9 s, fea 0.9 s, paths 0.6 s, splice 110 s, check
9.5 s: the splice (Python, per vertex and per path) is what is left to make fast.

And now (2026-12-02, the example from the cache, CPU profile, 5.8 s with the profiler): the splice
2.7 s (its Ramer-Douglas-Peucker passes 1.05 s, the rewrite and text 1.15 s), imports about 1.5 s
(numpy 0.56 s, the settings and engine registry 0.7 s), parse and geometry 0.5 s, the verdict 0.3 s
(the deposits and their hash).  The first run: linking 8.5 s of wall at load 10 (``accept``, one link
at a time: sequential by design), the prediction 10 s, the engine with its kernels' loading 9.6 s.

Measured 2026-12-02 (issue 17, third pass: linking shares one preparation and each candidate's test
between its two ways, fragments dropped on the neighbours cut to the short bead's box, the laid links'
tree rebuilt every 64 samples, straight candidates tested in one batched query, links made in the
worker processes; each layer's islands in the cache).  ``--quick --only example,gusset-gyroid30``,
one run each, BEFORE = 762a92d at load 2.5, AFTER = 1072d6f at load 2.2 (not side by side)::

    part                     slice s  first s     x  repeat s     x  peak MB  out/in  cpu:sl  first  repeat
    BEFORE
    example                     0.17    12.27  74.1      1.48   9.0      415    2.30     0.1   11.6     1.4
    gusset-gyroid30             0.57    21.51  37.8      6.82  12.0      370    1.06     0.5   14.2     4.5
    AFTER
    example                     0.22     8.22  37.9      1.33   6.1      416    2.30     0.2    7.0     1.1
    gusset-gyroid30             0.61     8.95  14.6      2.74   4.5      363    1.06     0.5    7.8     2.4

Outputs byte-identical (without the verdict line) and the same verdict on both parts, first and
repeated runs.  The linking of the example's 9 layers: 9.1 -> 2.3 s CPU (captured calls, the same
runs).  The 1000-layer file (commit 51f8c01, before the batched and parallel linking, load 8-10):
first run 1482 s wall, 501 s CPU, peak 13.5 GB: the verdict's bead model (about 12 M one-millimetre
pieces, several arrays each, and 1.1 GB of kept bead layers) holds the peak; not solved here.

Measured 2026-12-02 (issue 17, the verdict's memory: the bead pieces cut, measured and sampled a few
layers at a time, ``loadpath.stiffness.layered``; the engine's beads made from its paths when read).
The specimen at 100, 200 and 1000 layers (``slicing.ohs_mesh(thickness=0.2 N)``, the example's
settings), ``loadpath run --report`` on a cold cache under ``/usr/bin/time -v`` (its peak is the
largest single process's), load 1-3; BEFORE = 8338cfe (1000 layers: 51f8c01, the figure above),
AFTER = 750349d (chunks of 512 k pieces; 7dba47b's 128 k take another 110 MB off the verdict)::

    layers   wall s  CPU s  peak MB  verdict s  splice s     wall s  CPU s  peak MB  verdict s  splice s
             BEFORE                                          AFTER
    100        49.9   45.1     1622       22.9      17.7       44.0   43.1      614       16.0      21.3
    200       182.0  118.1     2899       86.8      76.6      113.0  101.3      781       44.0      54.1
    1000     1482.0  501.0    13500          -         -      644.6  432.5     1980      168.5     368.7
    1000 (7dba47b)                                           483.1  447.0     2001      169.0     230.5

The run without the verdict (``predict=False``, in process): 388 MB at 100 layers, 503 MB at 200:
the pipeline's own memory grows by about 115 MB per 100 layers, the verdict's now by about 50 (its
per-ply, per-element fields, 10 arrays of layers x elements, and the slicer's beads before and
kept); before, by 1.2 GB.  The verdict of the 100-layer specimen replayed in process (no cache):
peak 1392 -> 319 MB, CPU 20.3 -> 13.4 s, the same stiffness, failure and energy-ratio figures bit
for bit; the outputs of 100 and 200 layers byte-identical but for the verdict's minute.  Where
the 1000 layers' memory is now (7dba47b, in process, the analyses and paths from the cache, RSS
sampled every 50 ms): parse 456 MB, paths 783, splice 1506, verdict 1201, after it 1028: the verdict
is no longer the peak.  The cold run's 2.0 GB is not attributed (``/usr/bin/time`` gives the largest
process of the tree; the engine's workers hold 450 MB each at 1000 layers).  The 1 GB target is
still missed at 1000 layers (the pipeline alone extrapolates to 1.4 GB), and so is 15 s: the splice
(per layer Python: rewrite, bead runs, ordering) is now the largest item, then the verdict's bead
neighbour search (one KD-tree per layer and prediction, no two layers of the specimen alike).

Measured 2026-12-04 (issue 17, fourth pass: the splice 2.8-3.4x faster with the same bytes,
``benchmarks/bench_splice.py``; the verdict on ``loadpath compare``'s model with a sample budget, a
part over it not predicted and its output not parsed back), median of 3 (the 1000-layer file: one
run), load 1.2-1.8 on the 2 cores::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in
    example                      10     0.16     8.20   50.1      0.89    5.4      676    0.25   3.53
    specimen-100                100     0.42    12.80   30.3      3.97    9.4      460    2.31   4.26
    gusset-gyroid30              40     0.35     7.55   21.3      0.81    2.3      696    2.32   1.11
    gusset-gyroid30-sparse       40     0.34    51.14  148.7     12.94   37.6      702    2.32   0.54
    gusset-100                   40     0.36    17.26   47.5      2.40    6.6      723    0.64   5.89
    specimen-1000              1000     1.92   104.01   54.3     46.55   24.3     1833   22.95   4.35

The same morning, before the merges, at load 0.6: the sparse gusset 77.80 s first (229.4x), 59.35 s
repeated (175.0x); the 1000-layer file last measured at 483 s and 2001 MB.  The example's output is
3.53x its input here because this benchmark's load case (``GRIP_PULL``) is not the example's own
(2.47x with ``examples/ohs.toml``).

Measured 2026-12-04 (issue 17, fifth pass: the verdict's point location and bead sampling compiled,
``loadpath.fea.locate_kernel`` and ``loadpath.stiffness.sample_kernel``, bit-identical; its two
predictions side by side; the links' key names the field instead of sampling it; each repeat against
its own first run's cache, see ``Columns``).  BEFORE = 7cc532c, AFTER = branch ``lat``, run back to
back, median of 3, ``--only example,gusset-gyroid30`` at load 0.8 (AFTER) and 1.8 (BEFORE); the
100-layer specimen (not predicted: over the verdict's budget) in an earlier pair at load 2.4-3.5::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    BEFORE
    example                      10     0.22    10.17   45.9      0.88    4.0      676    0.25   3.53     0.2     9.9     0.8
    gusset-gyroid30              40     0.58     9.19   15.8      5.37    9.2      687    2.32   1.11     0.6     8.9     5.1
    specimen-100                100     0.60    20.22   33.9      5.47    9.2      409    2.31   4.26     0.5    20.4     5.1
    AFTER
    example                      10     0.18     4.25   23.7      0.63    3.5      257    0.25   3.53     0.2     6.5     0.7
    gusset-gyroid30              40     0.35     7.95   22.9      3.78   10.9      312    2.32   1.11     0.5     8.2     3.9
    specimen-100                100     0.52    19.33   37.5      5.59   10.8      410    2.31   4.26     0.5    19.3     5.3

The slicer's own time varies 0.35-0.71 s on the gusset between runs, so its ratios move more than
loadpath's seconds.  The same input files run alternately by both versions at load 0.9 (the example
and the bench's re-slice of it at other speeds; the gusset likewise), whole processes: example first
7.71 / 7.31 -> 4.26 / 4.73 s (CPU 9.2 / 8.9 -> 6.6 / 7.1 s, peak 691 -> 262 MB), repeat 0.66 / 0.66 -> 0.62 /
0.67 s; gusset first 8.62 / 8.03 -> 5.38 / 5.08 s, repeat 5.86 / 5.35 -> 3.72 / 3.80 s; outputs
byte-identical and the same verdict.  A repeat is a real re-export here: PrusaSlicer moves a few
perimeter vertices at other speeds (15 of the gusset's 40 layers), so those layers' engine runs,
links and both predictions are made again; the example's beads stay the same and its repeat
(0.6-0.9 s: imports 0.2 s, the splice of 8 blocks at the new speeds 0.3 s, check, parse, the verdict
from the cache) is unchanged.  Targets still missed: first run 3x (23-38x), repeat 1.5x (3.5-11x).

Measured 2026-12-04 (issue 17, the 1000-layer file's time and memory: the splice's blocks in the
worker processes, the check read piece by piece, layers whose region is their representative's
within 0.05 mm printing its linked runs, orders kept, freed heap pages given back), ``--only
example,specimen-1000``, median of 3, load 1.1-1.6; BEFORE = 7cc532c (main), AFTER = ceda7d6, one
after the other (the slicer's times differ between the two runs: compare the ratios)::

    part           slice s  first s     x  repeat s     x  peak MB  out/in  cpu:sl  first  repeat
    BEFORE
    example           0.13     9.90  75.4      0.86   6.6      676    3.53     0.1    9.3     0.8
    specimen-1000     3.54   143.40  40.5     38.20  10.8     1854    4.35     3.6  163.6    38.2
    AFTER
    example           0.15     9.55  61.9      0.63   4.1      655    3.53     0.2   10.5     0.8
    specimen-1000     2.13    26.44  12.4     18.06   8.5      750    4.35     3.9   38.6    27.6

(These AFTER figures include 07b5c0c, the reuse of a representative's linked runs, reverted the same
day: it made a CuraEngine file with combined sparse infill fail its check.  On the final code, same
day, load about 2, one run: specimen-1000 slice 2.44 s, first run 108.0 s (44.2x), repeat 39.1 s
(16.0x), peak 909 MB; example, median of 3: 0.17 s, 5.14 s (30.4x), 0.94 s (5.5x), 253 MB; gusset
0.44 s, 5.82 s (13.1x), 2.93 s (6.6x), 310 MB.)

The 1000-layer file with 07b5c0c: 1 GB met (750 MB); 15 s still missed (26.4 s first, 18.1 s repeated).  Where
its first run's CPU went before (in process, profiled): the linking of 1000 layers each in its own
region (816 distinct regions, 0.2-0.3 s each) 260 s of worker time, the splice 37 s, the check's
whole read of the 4.1M-line output 8 s and 1.05 GB.  Now (in process, one worker, profiled): the
splice about 30 s of CPU (rewrite 20: travels and retractions 8.7, extrusion text 6.1; plan 8; bead
runs 6.6; Python per path, 47k paths), split over the workers; the check 4.3 s; parse, geometry
and load case 4 s; 22 linkings 4.4 s.  Output byte-identical to BEFORE on the 1000-layer file; the
example and the 100-layer specimen print their representatives' runs (the reuse is a deliberate
change: 205 -> 214 and 4577 -> 4622 retractions, the example's failure load +5.0 -> +4.9 %).

Measured 2026-12-04 (issue 17, the splice's per-path Python trimmed, output byte-identical: a
wipe's points written in one pass, the chain-to-chain travels' region test one shapely call per
block, the E words and feedrate changes of a block's chains made in one pass, F/Z/width words
remembered, the 2-opt's travel costs from one table).  ``--only example,specimen-100,specimen-1000
--repeats 1``, BEFORE = 43e0073 (main), AFTER = branch ``splicefast``, one after the other at load
5.6-6.1 on the 2 cores (other jobs: wall times several times their idle value)::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    BEFORE
    example                      10     0.19     6.67   34.3      1.22    6.3      251    0.25   3.53     0.2     6.0     1.1
    specimen-100                100     0.54    13.95   25.7      8.64   15.9      439    2.31   4.27     0.5    10.0     5.7
    specimen-1000              1000     7.22    53.32    7.4     38.60    5.3      746   22.95   4.35     4.6    50.4    35.8
    AFTER
    example                      10     0.30     8.94   29.8      3.94   13.2      269    0.25   3.53     0.2     7.6     3.7
    specimen-100                100     0.61    10.42   17.2      5.59    9.2      455    2.31   4.27     0.5    10.0     5.4
    specimen-1000              1000     4.20    47.57   11.3     34.47    8.2      759   22.95   4.35     4.0    45.1    33.2

The example's AFTER repeat (3.7 s CPU) did not come again: ``--only example`` right after, AFTER
0.86 s (0.8 s CPU), BEFORE 0.95 s (0.8 s CPU); a manual repeat against a first run's cache took
3.5 s CPU on both versions, with identical output.  The splice alone, replayed in process on one
core from the 1000-layer file's repeated run (998 blocks, 47k paths): 20.3 -> 16.9 s CPU (-17 %);
profiled 32.5 -> 26.1 s (rewrite 19.4 -> 15.0, of which the chains' extrusion 6.4 -> 3.3 and the
travels 7.8 -> 5.8; plan 3.9 -> 2.8, its 2-opt 1.4 -> 0.5; bead runs 7.9 -> 7.1; ``fmt`` calls 1.49 M
-> 0.27 M).  What is left is flat: the bead runs' Ramer-Douglas-Peucker passes (3.2 s profiled), the
wipes (3.5 s), the block text (3.6 s), each per path or per level of numpy calls.

Measured 2026-12-04 17:45 UTC on main 94e2d58 (the splice above, the level-set engine's sparse
ends, the hardening fixes), load 1.1-1.5 on the 2 cores, every part; swarm median of 3, level sets
one run (the 1000-layer file one run in both)::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    swarm
    example                      10     0.18     4.66   25.9      0.69    3.8      251    0.25   3.53     0.2     7.0     0.9
    specimen-100                100     0.36     7.51   21.1      5.49   15.4      440    2.31   4.27     0.6     9.6     6.9
    gusset-gyroid30              40     0.44     5.94   13.4      3.77    8.5      309    2.32   1.11     0.7     8.1     4.7
    gusset-gyroid30-sparse       40     0.37    17.57   48.0     11.93   32.6      332    2.32   0.52     0.6    26.3    13.9
    gusset-100                   40     0.36     7.44   20.9      6.37   17.9      318    0.64   5.92     0.5    11.8     9.3
    specimen-1000              1000     2.45    31.37   12.8     25.73   10.5      746   22.95   4.35     4.5    43.3    36.0
    levelset
    example                      10     0.21     5.82   28.2      0.71    3.5      380    0.25   2.59     0.2     9.8     0.9
    specimen-100                100     0.40     6.96   17.3      3.29    8.2      400    2.31   3.10     0.6    10.0     3.9
    gusset-gyroid30              40     0.40     6.22   15.6      2.38    5.9      273    2.32   1.07     0.6     9.0     3.7
    gusset-gyroid30-sparse       40     0.37    14.61   39.9      8.92   24.3      299    2.32   0.43     0.6    18.9    10.8
    gusset-100                   40     0.33     6.11   18.4      6.13   18.4      261    0.64   4.09     0.5    10.4    10.3
    specimen-1000              1000     2.25    24.67   11.0     16.37    7.3      631   22.95   3.15     4.1    33.3    22.2

Every target but the 1000-layer file's memory is still missed.  The floor for the small parts:
``python -c "import numpy, scipy.sparse.linalg, shapely, osqp"`` (the base dependencies alone)
takes 0.33 s here, 1.8-2.5x PrusaSlicer's whole slicing of the example (0.13-0.18 s).

Measured 2026-12-04 (issue 17, lean output: the new moves' X/Y to 2 decimals and relative E to 4,
the bead runs simplified again with their starts fixed).  ``--repeats 1 --only
example,specimen-100,gusset-100``, per engine, BEFORE = e3abbda (main) and AFTER = branch ``lean``
run at the same time (load 5-7 on the 2 cores, shared with other jobs: compare ``out/in``, the
times only loosely)::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    BEFORE swarm
    example                      10     1.27    33.67   26.4      5.26    4.1      252    0.25   3.53     0.2     7.1     1.0
    specimen-100                100     2.48    55.98   22.6     21.80    8.8      438    2.31   4.27     0.5    10.8     6.2
    gusset-100                   40     1.99    36.34   18.2     16.55    8.3      317    0.64   5.91     0.6    14.1     6.7
    AFTER swarm
    example                      10     0.17     6.61   39.4      1.73   10.3      266    0.25   3.20     0.2     6.5     0.9
    specimen-100                100     0.95    25.93   27.3      9.36    9.9      446    2.31   3.82     0.5    10.4     5.1
    gusset-100                   40     0.78    14.07   18.1      8.78   11.3      329    0.64   5.46     0.5    10.9     5.7
    BEFORE levelset
    example                      10     0.54    22.91   42.2      2.22    4.1      381    0.25   2.59     0.2     9.0     0.7
    specimen-100                100     1.49    18.46   12.4      6.55    4.4      400    2.31   3.10     0.6     8.3     4.4
    gusset-100                   40     0.78    13.67   17.5     15.44   19.8      264    0.64   4.24     0.5    10.7    10.2
    AFTER levelset
    example                      10     0.30    13.61   44.8      0.78    2.6      400    0.25   2.33     0.2     8.7     0.7
    specimen-100                100     0.91    14.55   15.9      6.18    6.8      419    2.31   2.75     0.6     9.3     4.1
    gusset-100                   40     0.68    18.65   27.3      9.51   13.9      276    0.64   3.84     0.4    12.7     6.4

``out/in`` 0.89-0.92x of BEFORE's on all six; the 1.5x target is still missed.  Where the bytes
go (AFTER, swarm): the new infill's ``G1 X Y E`` lines are 76-80 % of the file (25 bytes each,
28 before), at 0.20 (example, specimen) to 0.63 (gusset, curving round its holes) vertices per
mm of bead against the slicer's 0.055-0.10 (long straight lines); ``;WIDTH:`` markers 6-7 %; the
per-path travel, wipe, retraction, Z-hop and feedrate lines 10-23 % (gusset, swarm: 3670 travels).
The vertex count is held by the linked runs' 10 % bound (``RunOptions.linked_resolution``) on
curved paths: G2/G3 arcs, where the file's settings allow them, are what is left to cut it.

Measured 2026-12-04 19:45-19:57 UTC (issue 17, branch ``fast1000``: the cold geometry's islands and the
units' overlap regions made in the worker processes, the same bytes).  ``--repeats 1 --only
specimen-100,specimen-1000``, BEFORE = main c606cf6 (its code for these parts is e3abbda's) and AFTER
one after the other, swarm then level sets, at load 4.5-8.7 on the 2 cores (four jobs sharing them)::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    swarm BEFORE (load 5.6)
    specimen-100                100     1.17    19.73   16.8     14.99   12.8      438    2.31   4.27     0.5     9.8     7.4
    specimen-1000              1000     9.67   125.21   12.9     64.97    6.7      770   22.95   4.35     4.7    61.4    37.7
    swarm AFTER (load 8.1)
    specimen-100                100     0.81    15.53   19.1     18.71   23.0      461    2.31   4.27     0.6    10.6     9.7
    specimen-1000              1000     8.62    85.95   10.0     49.08    5.7      753   22.95   4.35     4.4    53.2    32.5
    levelset BEFORE (load 6.1)
    specimen-100                100     0.90    13.75   15.2      4.63    5.1      400    2.31   3.10     0.6     9.3     4.3
    specimen-1000              1000     3.14    32.86   10.5     26.70    8.5      635   22.95   3.16     4.0    32.0    25.7
    levelset AFTER (load 4.4)
    specimen-100                100     0.53    11.90   22.6      5.20    9.9      411    2.31   3.10     0.5     8.2     3.5
    specimen-1000              1000     6.42    53.23    8.3     22.53    3.5      636   22.95   3.15     4.3    35.3    22.5

At this load the wall times measure the other jobs (the slicer's own 1000-layer slicing took 3.1-9.7 s);
the CPU columns are comparable and did not change beyond noise: the change moves about 6-8 s of one
core's work (the 1000-layer file's cold islands 4.7-5.2 s of CPU, its 998 units' overlap 1.4-2.8 s) off
the main process, a gain only where a core is free.  In process (``plugin.job.run_job``, fresh cache,
one run each): at load 1.8-2.2, BEFORE geometry 5.46 s and load case 1.46 s (run 35.6 s), AFTER 2.75 s and
0.89 s (run 28.0 s); at load 5-6, alternated twice, geometry 5.51 / 6.39 -> 5.25 / 5.16 s: no free core, no
gain.  Where the 1000-layer file's cold run goes (in process, load 1.8-2.2, main): parse 1.6 s, geometry
5.5, load case 1.5 (the overlap), FEA 0.6, engine 2.3, linking and splice 19.6 (the splice about 20 s of
CPU in two workers: rewrite 60 %, bead runs 25 %, plan 11 %), check 3.9 (one process, piece by piece),
verdict 0.3, write 0.3.  Output byte-identical to e3abbda's (but the verdict line) on the 1000-layer
file's first and repeated runs with both engines and the 100-layer specimen's with the swarm.

Measured 2026-12-04 20:44-20:54 UTC on main after the merges of the day (lean digits 2 / 4 still on,
since set back to the slicer's 3 / 5: outputs about 9 % larger than the ``out/in`` here), load 1.0
at the start, ``--repeats 3`` (swarm) and ``--repeats 1 --engine levelset``::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    swarm
    example                      10     0.16     3.87   24.7     3.51   22.4      252    0.25   3.20     0.2     5.8     5.1
    specimen-100                100     0.32     6.05   19.1     3.60   11.4      433    2.31   3.82     0.5     8.5     4.8
    gusset-gyroid30              40     0.40     5.76   14.4     2.94    7.4      309    2.32   1.10     0.6     8.2     4.0
    gusset-gyroid30-sparse       40     0.36    18.55   50.8    22.35   61.3      331    2.32   0.54     0.6    27.2    31.9
    gusset-100                   40     0.44     8.35   19.2     5.47   12.6      316    0.64   5.46     0.6    13.1     8.2
    specimen-1000              1000     2.44    36.73   15.0    29.39   12.0      704   22.95   3.89     4.5    53.3    44.0
    levelset
    example                      10     0.21     6.38   30.5     0.94    4.5      382    0.25   2.30     0.2    10.8     1.1
    specimen-100                100     0.37     6.23   17.0     3.71   10.1      394    2.31   2.72     0.6     9.4     4.6
    gusset-gyroid30              40     0.55     6.97   12.6     5.59   10.1      274    2.32   1.06     0.8    11.1     9.6
    gusset-gyroid30-sparse       40     0.53    14.17   26.7    10.57   19.9      297    2.32   0.38     0.8    19.3    13.2
    gusset-100                   40     0.32     7.59   23.7     4.53   14.1      265    0.64   3.80     0.5    12.7     6.5
    specimen-1000              1000     2.20    22.72   10.3    18.25    8.3      630   22.95   2.76     4.0    35.3    27.2

The swarm's example repeat (3.51 s, 5.1 s of CPU) is the re-slice at other speeds run against the
shipped file's cache: its layers' engine runs and links are made again (the same two runs against
a cache that has seen the re-slice: 0.84-1.06 s); the code before the day's merges (70446c6) gives
the same on these two files (6.16 s, then 1.01 s). The gyroid gusset's sparse repeat takes longer
than its first run (31.9 against 27.2 s of CPU): not explained here.

Measured 2026-12-04 22:26-22:33 UTC (issue 17, the splice's second pass, ``bench_splice.py``: the
1000-layer splice 19.3 -> 17.6 s of CPU, byte-identical), ``--repeats 1 --only specimen-1000``,
BEFORE = 89dc3f2 (main's ``core`` on ``PYTHONPATH``) and AFTER = branch ``splicefast``, in the order
BEFORE, AFTER, AFTER, BEFORE at load 2.2-5.1 on the 2 cores (other jobs; the first BEFORE ran as
the load rose to 5 and is the outlier)::

    part           slice s  first s      x repeat s      x  peak MB  out/in  cpu:sl  first  repeat
    BEFORE         1.95      48.20   24.7     47.94   24.6      815    4.26     3.5   43.6    34.3
    AFTER          5.29      41.39    7.8     30.53    5.8      775    4.26     3.5   39.3    29.4
    AFTER          3.65      41.97   11.5     31.25    8.6      768    4.26     3.5   39.7    29.9
    BEFORE         3.53      42.67   12.1     32.58    9.2      775    4.26     3.5   40.8    31.8

The second pair, back to back: first run 42.7 -> 42.0 s (CPU 40.8 -> 39.7), repeated 32.6 -> 31.3 s
(CPU 31.8 -> 29.9); the same output size; 15 s still missed by 2.8x.

Measured 2026-12-04 22:43-22:50 UTC on ec0f5fb (the splice's second pass merged), load 1.3 at the
start, nothing else of this project running but a one-minute edit of the verdict's cache (reverted
before the gusset's sparse runs had all started; their figures may hold one run of it),
``--repeats 3`` (swarm)::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    example                      10     0.13     3.73   28.6     2.16   16.5      252    0.25   3.47     0.1     5.7     3.6
    specimen-100                100     0.36     5.97   16.4     5.73   15.7      442    2.31   4.18     0.6     8.2     7.9
    gusset-gyroid30              40     0.33     5.18   15.8     2.11    6.5      309    2.32   1.11     0.5     7.4     3.4
    gusset-gyroid30-sparse       40     0.33    18.36   55.6     8.38   25.4      330    2.32   0.53     0.5    23.2    10.0
    gusset-100                   40     0.38     7.34   19.1     5.22   13.6      317    0.64   5.99     0.4     9.9     5.9
    specimen-1000              1000     2.74    28.82   10.5    24.03    8.8      736   22.95   4.26     3.4    36.2    27.9

Then on 62b4637 (the verdict's predictions also kept for beads within 0.1 mm, :func:`loadpath.stiffness.change.near_key`:
PrusaSlicer's re-export at other speeds moves a few beads by hundredths of a millimetre), 22:50-22:53,
``--repeats 3 --only example,specimen-100,gusset-gyroid30``, load 1.6::

    example                      10     0.13     3.64   27.1     0.63    4.7      252    0.25   3.47     0.1     5.5     0.8
    specimen-100                100     0.30     5.54   18.4     3.30   11.0      436    2.31   4.18     0.5     7.7     4.3
    gusset-gyroid30              40     0.32     4.38   13.6     3.95   12.2      309    2.32   1.11     0.5     6.5     5.0

The example's repeat 2.16 -> 0.63 s (CPU 3.6 -> 0.8): both predictions from the near match.  The
100-layer specimen is over the verdict's sample budget and not predicted: the near match does not
touch it, and its repeat's 5.73 against 3.30 s between the two runs is not explained here.  The
gusset's re-slice changes its gyroid layers (other layers, roles and counts: no near match), so both
predictions and two jobs' paths are made again as before; its repeat's 2.11 against 3.95 s between
the two runs is PrusaSlicer's re-slice differing from run to run (in process on one pair of files:
two of five engine jobs and both predictions made again, 2.46 s).

2026-12-05, 00:12-00:17 (main 809800a, load 0.2) and 00:47-00:56 (after this stop's changes, load
0.6), ``--repeats 3``::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    BEFORE (809800a)
    example                      10     0.12     3.50   28.2     0.60    4.8      251    0.25   3.47     0.1     5.3     0.8
    specimen-100                100     0.29     5.49   19.0     3.60   12.5      435    2.31   4.18     0.5     7.7     4.7
    gusset-gyroid30              40     0.32     4.96   15.7     2.15    6.8      309    2.32   1.11     0.5     7.1     3.4
    gusset-gyroid30-sparse       40     0.31    15.81   50.4     9.61   30.7      332    2.32   0.53     0.5    22.4    12.3
    gusset-100                   40     0.27     5.70   21.5     3.26   12.3      316    0.64   5.89     0.4     9.2     5.3
    specimen-1000              1000     1.81    21.45   11.8    17.22    9.5      741   22.95   4.26     3.4    33.6    26.1
    AFTER
    example                      10     0.12     3.47   27.8     0.59    4.7      251    0.25   3.47     0.1     5.4     0.8
    specimen-100                100     0.29     4.75   16.4     4.26   14.7      327    2.31   4.29     0.5     7.6     6.8
    gusset-gyroid30              40     0.33     5.23   16.0     2.81    8.6      309    2.32   1.11     0.5     7.6     4.3
    gusset-gyroid30-sparse       40     0.33    15.67   48.1    12.47   38.3      331    2.32   0.60     0.5    23.0    18.6
    gusset-100                   40     0.27     5.66   21.3     4.82   18.1      316    0.64   5.89     0.4     9.4     7.5
    specimen-1000              1000     1.84    22.84   12.4    18.85   10.3      734   22.95   4.26     3.4    35.8    28.8

What changed: the verdict's counts of the replaced blocks are made beside the splice check in a
second process (they were a parse of the whole output after it), their print times from two
running minima instead of two Python loops, ``Program.move_rows`` without a copy of the line column
per call, and the cache's eviction reads a ledger instead of listing the folder after every write.
The rows above mix that with PrusaSlicer's own variance: it slices the same STL differently from
run to run (the skirt's start, a few perimeter vertices: 6686 diff lines between two slices of the
100-layer specimen a few minutes apart), so a run's paths, and whether a repeat finds them, move
with it (the 100-layer specimen's output 4.18 -> 4.29x the input, its repeat re-laid).  On fixed
files (the same slices for both, each version run three times in turn, medians; outputs and verdict
lines identical): example first 3.39 -> 3.52 s, repeat 0.59 -> 0.59 s; 100-layer specimen first
5.42 -> 4.39 s (peak 444 -> 330 MB), repeat 3.20 -> 2.17 s (in process: verdict 1.13 -> 0.04 s);
gusset 100 % first 5.99 -> 5.83 s, repeat 5.05 -> 4.74 s.  The 1000-layer file is over the
verdict's line budget (no counts), so none of it applies there; its 1.4-1.6 s between the two runs
is the machine.  With the user's own cache full (1 GiB, 17 600 entries here), each eviction listed
every entry: 0.12 s a scan, four a run.  The example run against this machine's full default cache
(``~/.cache/loadpath``), the analysis kept and the paths not (another ``--K`` each run), versions in
turn: 809800a 5.40, 4.10, 4.03 s; after 3.55 (its first run lists the folder once and cuts it to
90 %), 2.98, 3.06 s.

Tried and not kept: reusing a block's plan and bead runs for later blocks of the same paths (53 %
of the 1000-layer splice's CPU).  Keyed on everything they read, 914 of its 1016 blocks are
distinct: the regions found from PrusaSlicer's perimeters differ in the last digits on 812 of
them, the slicer's filament per block takes 473 values, and the start point 172; a key within a
tolerance would make a block's bytes depend on which block a worker laid first.

2026-12-05, 07:51-08:01 (main 85aa8b3, load 0.7), ``--repeats 3``::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    example                      10     0.14     3.67   26.4     0.61    4.4      251    0.25   3.47     0.2     5.6     0.8
    specimen-100                100     0.32     4.92   15.3     2.74    8.5      323    2.31   4.18     0.5     7.8     4.5
    gusset-gyroid30              40     0.33     5.31   16.2     5.14   15.7      309    2.32   1.11     0.5     7.7     7.5
    gusset-gyroid30-sparse       40     0.37    12.37   33.6    12.27   33.3      327    2.32   0.53     0.6    18.5    18.6
    gusset-100                   40     0.34     6.39   18.9     3.36   10.0      316    0.64   5.89     0.5    10.3     5.7
    specimen-1000              1000     1.96    19.21    9.8    13.57    6.9      720   22.95   4.26     3.6    32.5    22.0

What changed: the splice check reads its pieces in one group per worker side by side, each from a
guessed start checked against where the group before it ended (:mod:`loadpath.splice.piecewise`;
the 1000-layer output's check 3.28 -> 1.91 s); a splice of 2 million path vertices or more runs
its RDP pass and its bead runs' run index compiled (:mod:`loadpath.splice.compiled`; the
1000-layer splice 16.5 -> 13.3 s of CPU); a layer's reused runs are tested against its region by
the lines that meet its edge only (0.85 -> 0.23 s on the 1000-layer file); ``density = "auto"``
reads its candidates and the slicer's file for the part's body alone (their geometry 3.4 -> 0.7 s
on the sparse gusset); the linking's long links and clearance pairs in batches (0.47 -> 0.37 s of
CPU a sparse gusset layer).  The gusset's default repeat (5.14 s, 2.12 s in the morning's run
of the code without the last three changes) re-laid paths PrusaSlicer's re-slice moved.  On fixed
files, 3750756 (before) and 85aa8b3 (after) in turn, twice each, first on an empty cache and
repeat on the same part re-sliced at other speeds, outputs byte-identical but for the verdict's
timestamp, load 0.8-1.9: example 3.54, 3.25 -> 3.29, 3.43 s (its repeat, on a re-slice of the
STL that moves more than the example's own slicing, 2.03, 1.90 -> 1.82, 1.90 s); 100-layer
specimen 4.83, 4.62 -> 4.53, 4.67 s, repeat 2.75, 2.64 -> 2.57, 2.67 s (under the compiled
loops' 2 million vertices, its check beside the verdict's counts: nothing of this applies);
gusset, sparse replaced, first 13.43, 13.28 -> 11.83, 12.40 s, repeat 11.50, 11.33 -> 8.14, 8.52 s;
1000-layer specimen first 22.41, 22.44 -> 18.15, 19.79 s (peak 753 -> 737 MB), repeat 18.04,
18.51 -> 13.78, 15.14 s (peak 576 -> 679 MB: the check's two groups read side by side).

2026-12-05, 22:45-22:57 (main c6e8667, load 0.8), ``--repeats 3``::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    example                      10     0.12     3.89   31.2     0.52    4.2      357    0.25   2.51     0.1     6.5     0.7
    specimen-100                100     0.29     4.18   14.4     2.02    6.9      375    2.31   3.00     0.5     7.0     3.4
    gusset-gyroid30              40     0.33     7.48   22.7     6.89   20.9      354    2.32   1.07     0.5    10.9    10.3
    gusset-gyroid30-sparse       40     0.33    10.53   31.8    10.45   31.6      333    2.32   0.39     0.5    16.1    16.1
    gusset-100                   40     0.27     9.81   36.2     5.80   21.4      350    0.64   4.11     0.4    15.8     8.5
    specimen-1000              1000     1.86    14.71    7.9    10.53    5.7      616   22.95   3.04     3.4    24.7    16.5

The 1000-layer file's first runs were 14.71, 15.21 and 14.55 s: under 15 s by its median, not by a
margin (15.36 s at 20:47 the same day, 18.3 s at 21:50 with something else on the machine).  What
changed: ``density = "auto"`` and the solid layouts' choice judge each candidate through the run's
cache (:class:`loadpath.plugin.density_choice.Judge`: the verdict's ``predicted_change``, the same
figures bit for bit), so a run of the same file again judges from the cache (the sparse gusset in
process, same file, 5.94 -> 2.21 s); this table's repeat is a re-slice at other speeds, whose
moved perimeters make the sparse gusset lay 21 of its 42 engine runs again, and so predict its
candidates again (no gain there).  Measured from the checkout itself: the same bench run from a
second worktree through ``PYTHONPATH`` gave the 100-layer specimen's repeat 4.1 s against 1.75 s
here, both codes alike (its repeats missed the cache; not looked into further).

2026-12-06, 01:59-02:12 UTC (main aec0899, load 1.7), ``--repeats 3``::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    example                      10     0.14     4.10   30.2     0.55    4.0      357    0.25   2.51     0.1     6.7     0.8
    specimen-100                100     0.30     4.61   15.6     1.73    5.8      375    2.31   3.00     0.5     7.6     2.8
    gusset-gyroid30              40     0.32     8.35   26.0     2.66    8.3      353    2.32   1.07     0.5    12.1     3.4
    gusset-gyroid30-sparse       40     0.33    11.70   35.5     7.91   24.0      334    2.32   0.39     0.5    17.6    11.9
    gusset-100                   40     0.27    10.66   38.9     3.12   11.4      349    0.64   4.11     0.4    17.1     4.3
    specimen-1000              1000     1.96    16.04    8.2    10.92    5.6      618   22.95   3.04     3.6    26.8    17.2

What changed: near matches in the cache.  PrusaSlicer 2.5 on all its threads does not write the same
file twice: a re-slice of the gusset writes a third of its layers' perimeters and sparse lines in
another order, and moves its outlines and solid-infill regions by up to 13.5 um.  Every kept
prediction (matched bead for bead) and 6 of its 13 engine runs (keyed on the region to 1 um) missed,
so the repeat laid, linked and judged again.  Now a prediction serves a file that lays the same
material (:mod:`loadpath.stiffness.near`), and an analysis, an engine run and a linking serve outlines
and regions within ``TOL.region_reuse_mm`` (:func:`loadpath.pipeline.paths.near_input`).  The same
files in process: the default gusset's repeat 4.0 -> 1.4-1.6 s, the sparse one's 4.7 -> 2.6 s.
The bench's repeats vary with the slices PrusaSlicer happens to write: the default gusset 2.66 s
here, 2.33 s (e35a188, 02:10) and 4.54 s (c2e8277, 02:20) in two more runs (7.52 and 7.68 s before,
c6e8667 and 4adfcf0); the sparse gusset 7.91, 8.59 and 6.51 s (11.14 and 10.99 s before); the 100 %
gusset 3.12, 3.25 and 6.02 s (6.39 and 4.07 s before).  Where it is still slow a unit's region moved
further than its run's representative's and its paths are clipped and linked again: the clipped
paths differ, so their links and the predictions of the layouts they are in are made again (the
100 % gusset in process: 7 of 16 linkings, 2 of 3 predictions).  First runs are unchanged (the same
work; ``bench_printability.py --engine default`` on the same slices with an empty cache: all 18 rows
identical).  The 1000-layer file's first run is over 15 s on this machine today: 16.04 s here, 21.1 s
at 00:35 and 22.4-25.0 s as a process (the code of c6e8667 alike, 25.9 s), against 14.71 s last
night.

2026-12-07, 07:32-07:40 UTC (main f963450, load 1.0-1.2), ``--repeats 3``; the three gusset rows run
again by themselves (``--only``, 07:38-07:41), the first time having shared the machine with a test
run::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    example                      10     0.12     3.53   29.0     0.50    4.1      299    0.25   2.51     0.1     5.8     0.7
    specimen-100                100     0.30     3.96   13.4     4.08   13.8      317    2.31   2.98     0.4     6.5     6.6
    gusset-gyroid30              40     0.34    10.30   30.4     2.31    6.8      378    2.32   1.02     0.5    14.9     3.0
    gusset-gyroid30-sparse       40     0.32    13.44   41.7     8.03   24.9      333    2.32   0.25     0.5    20.2    10.4
    gusset-100                   40     0.27    13.35   49.5     8.38   31.1      359    0.64   1.90     0.4    21.3    10.6
    specimen-1000              1000     1.86    15.19    8.2    10.28    5.5      618   22.95   3.04     3.4    25.2    16.1

Every target missed, the 1000-layer file's 15 s by 0.19 s (its peak, 618 MB, under 1 GB).  The
repeats move with PrusaSlicer's own re-slice (its threads write the same part differently): the
100-layer specimen's 4.08 s here against 1.73 s on 2026-12-06, the 100 % gusset's 8.38 s against
3.12 s (4.82 s in this morning's first pass).  The 100 % gusset's output is 1.90x its input (4.11x
on 2026-12-06); this morning its solid choice lays the level sets through the cut (a tie within the
model's spread: 227 retractions against 891 and 2858); which layout the run of 2026-12-06 chose is
not known.

Measured 2026-12-07 10:03-10:08 UTC on dcceaa0 (the engines and the PrusaSlicer path as above; the
changes since touch CuraEngine files and messages), load 0.2 at the start, nothing else running,
``--repeats 3``::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    example                      10     0.12     3.50   29.2     0.51    4.2      299    0.25   2.51     0.1     5.7     0.7
    specimen-100                100     0.29     3.98   13.7     1.73    6.0      317    2.31   2.99     0.4     6.5     2.8
    gusset-gyroid30              40     0.33    10.58   32.3     2.46    7.5      378    2.32   1.02     0.5    15.3     3.2
    gusset-gyroid30-sparse       40     0.33    14.50   44.4     4.16   12.7      335    2.32   0.25     0.5    21.6     5.8
    gusset-100                   40     0.28    13.97   50.2     8.60   30.9      361    0.64   1.92     0.4    22.7    11.0
    specimen-1000              1000     1.87    14.53    7.8    10.12    5.4      617   22.95   3.04     3.4    24.4    15.9

The 1000-layer file's three first runs 14.35-14.59 s: under 15 s this time, by less than the run
to run spread of the mornings above (15.19 s; 14.7 s on 2026-12-06), so met without margin; every
ratio target still missed.

Measured 2026-12-07 17:43-17:53 UTC on another machine (main 697faac, the code of the run as above;
load 1.3 at the start; the first three rows shared the cores with a single-process experiment, the
last three did not), ``--repeats 3``::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    example                      10     0.23     7.36   32.4     0.91    4.0      301    0.25   2.51     0.2    11.3     1.2
    specimen-100                100     0.54     6.87   12.8     3.97    7.4      319    2.31   2.99     0.9    10.4     4.5
    gusset-gyroid30              40     0.81    19.84   24.4     4.77    5.9      386    2.32   1.02     0.9    24.3     5.1
    gusset-gyroid30-sparse       40     0.86    36.53   42.5    23.23   27.0      358    2.32   0.25     0.9    36.9    21.1
    gusset-100                   40     0.39    21.48   54.9     5.99   15.3      370    0.64   1.90     0.6    33.7     8.6
    specimen-1000              1000     3.38    20.76    6.1    13.33    3.9      627   22.95   3.04     6.3    34.2    20.6

This machine does the same work in about 1.8x the CPU seconds (PrusaSlicer's own slicing: 0.2 / 0.9 /
6.3 s of CPU against 0.1 / 0.5 / 3.4 s on the rows above): the ratios moved little (the 1000-layer
file 7.8x -> 6.1x), the 15 s bound is missed by its absolute figure (20.8 s).  The same file in process
(``plugin.job.run_job``, empty cache, two workers) took 17.2 s: parse 1.72, geometry 2.72, load case
1.09, FEA 0.44, paths 3.76, splice 4.35, check 2.28, verdict 0.33, write 0.13 s; on one core (profiled,
32.6 s) its splice was 10.8 s of CPU (the rewrite 4.8 with its block text 2.0, bead runs 3.7, the plan 1.4),
the islands 4.9 (the walls' bead unions 1.75), the check 3.6, the linking 3.4, the engine 3.1:
no item holds more than a third, and none a hotspot of its own.

The verdict's bead sampling tries each sample point in the element of the point before it first
(``loadpath.stiffness.sample_kernel.HINT``; the same sums bit for bit).  ``--only
example,gusset-gyroid30,gusset-gyroid30-sparse --repeats 3``, AFTER = edd666c and BEFORE = 9bbecc8 (run
from a second worktree through ``PYTHONPATH``), one after the other, 18:13-18:19 UTC, load 0.8-1.6::

    part                     layers  slice s  first s      x repeat s      x  peak MB   in MB out/in  cpu:sl   first  repeat
    BEFORE
    example                      10     0.16     4.99   30.5      0.67    4.1      300    0.25   2.51     0.2     8.3     0.9
    gusset-gyroid30              40     0.42    14.04   33.4      4.29   10.2      378    2.32   1.02     0.7    20.1     5.3
    gusset-gyroid30-sparse       40     0.43    20.17   47.1     11.77   27.5      334    2.32   0.25     0.7    29.7    14.6
    AFTER
    example                      10     0.17     4.67   28.2      0.74    4.5      300    0.25   2.51     0.2     7.3     1.0
    gusset-gyroid30              40     0.43    13.29   30.8      4.75   11.0      379    2.32   1.02     0.7    19.9     5.9
    gusset-gyroid30-sparse       40     0.53    17.42   32.9      5.57   10.5      333    2.32   0.25     0.9    26.1     7.6

The example's first run 1.0 s of CPU less (its two predictions run side by side, so 0.3 s of wall);
the sparse gusset, which predicts each density candidate, 3.6 s of CPU less on its first run and 7.0
s on its repeat (whose re-slice moves perimeters, so both candidates are predicted again).  The
example's 12 sampling batches on one core: 3.04 -> 0.43-0.72 s.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "benchmarks"))
import slicing  # noqa: E402
from bench_pipeline import _child  # noqa: E402
from cases import GRIP_PULL  # noqa: E402

LOADPATH = str(Path(sys.executable).with_name("loadpath"))

# the same part re-exported with other speeds and temperatures: nothing the geometry, the FEA or the
# paths depend on changes
OTHER_SPEEDS = {
    "perimeter_speed": "30",
    "external_perimeter_speed": "20",
    "infill_speed": "150",
    "solid_infill_speed": "120",
    "top_solid_infill_speed": "40",
    "travel_speed": "150",
    "temperature": "210",
    "first_layer_temperature": "220",
}
GUSSET = {
    **slicing.PRUSA_MIXED,
    "fill_density": "30%",
    "fill_pattern": "gyroid",
    "top_solid_layers": "3",
    "bottom_solid_layers": "3",
}
GUSSET_SOLID = {**GUSSET, "fill_density": "100%", "fill_pattern": "rectilinear"}
SOLID_PARTS = ("example", "specimen-100", "gusset-100", "specimen-1000")
"""Parts printed all solid: the ones the output-size target (<= 1.5x the input) applies to."""


def gusset_mesh(leg: float = 60.0, thickness: float = 8.0, hole: float = 5.0):
    """A shelf gusset: right-triangle plate with two bolt holes near the legs, mm."""
    import manifold3d as mf
    import numpy as np
    import trimesh

    cs = mf.CrossSection([[(0, 0), (leg, 0), (0, leg)]])
    for c in ((0.45 * leg, 0.12 * leg), (0.12 * leg, 0.45 * leg)):
        cs = cs - mf.CrossSection.circle(hole / 2, 48).translate(c)
    m = mf.Manifold.extrude(cs, thickness).to_mesh()
    mesh = trimesh.Trimesh(np.asarray(m.vert_properties)[:, :3], np.asarray(m.tri_verts))
    mesh.apply_translation(-mesh.bounds[0])
    return mesh


def _cpu() -> float:
    """CPU seconds (user + system) of every child process waited for so far."""
    import resource

    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def _slice(stl: Path, out: Path, repeats: int, settings: dict) -> tuple[float, float]:
    times, cpu = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), _cpu()
        slicing.slice_prusa(stl, out, one_cpu=False, **settings)  # timed as the user runs it
        times.append(time.perf_counter() - t)
        cpu.append(_cpu() - c)
    return statistics.median(times), statistics.median(cpu)


def _run(gcode: Path, case: Path, out: Path, cache: Path, extra: list[str], timeout: float):
    env = {**os.environ, "LOADPATH_CACHE_DIR": str(cache)}
    # an installed loadpath has its bytecode compiled (pip does it); a development shell that forbids
    # writing it would make every run compile ~100 modules again (0.4 s of CPU), which no user sees
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    cmd = [LOADPATH, "run", str(gcode), "--loadcase", str(case), "-o", str(out), *extra]
    c = _cpu()
    wall, rss, status, err = _child(cmd, timeout=timeout, env=env)
    if status != 0:
        raise SystemExit(f"loadpath run failed on {gcode.name}: {err}")
    return wall, rss, _cpu() - c


def bench(name, stl, settings, folder: Path, repeats: int, extra: list[str], timeout: float, given=None):
    """One row: slicing time, first and repeated runs, peak memory, sizes."""
    from loadpath import gcode as gc

    case = folder / "case.toml"
    case.write_text(GRIP_PULL, encoding="utf-8")
    sliced = folder / f"{name}.gcode"
    row: dict = {"part": name, "options": " ".join(extra)}
    row["prusaslicer_s"], row["prusaslicer_cpu_s"] = _slice(stl, sliced, repeats, settings)
    gcode = given if given is not None else sliced
    other = slicing.slice_prusa(stl, folder / f"{name}.speeds.gcode", **{**settings, **OTHER_SPEEDS})
    row["layers"] = len(gc.read(gcode).layers)
    out = folder / f"{name}.loadpath.gcode"
    first, repeat, rss = [], [], []
    cpu: dict[str, list[float]] = {"first": [], "repeat": []}
    for k in range(repeats):
        w, m, c = _run(gcode, case, out, folder / f"cache-{name}-{k}", extra, timeout)
        first.append(w)
        rss.append(m)
        cpu["first"].append(c)
    row["size_in_mb"] = gcode.stat().st_size / 1e6
    row["size_out_mb"] = out.stat().st_size / 1e6
    for k in range(repeats):  # each against the cache of one first run only: a re-export as a user makes it
        again = folder / f"{name}.speeds.loadpath.gcode"
        w, m, c = _run(other, case, again, folder / f"cache-{name}-{k}", extra, timeout)
        repeat.append(w)
        rss.append(m)
        cpu["repeat"].append(c)
    row["first_cpu_s"], row["repeat_cpu_s"] = (statistics.median(cpu[k]) for k in ("first", "repeat"))
    row["first_s"], row["first_s_all"] = statistics.median(first), first
    row["repeat_s"], row["repeat_s_all"] = statistics.median(repeat), repeat
    row["peak_rss_mb"] = max(rss)
    return row


def _show(r: dict) -> None:
    s = r["prusaslicer_s"]
    print(
        f"{r['part']:<24}{r['layers']:>7}{s:>9.2f}{r['first_s']:>9.2f}{r['first_s'] / s:>7.1f}"
        f"{r['repeat_s']:>9.2f}{r['repeat_s'] / s:>7.1f}{r['peak_rss_mb']:>9.0f}"
        f"{r['size_in_mb']:>8.2f}{r['size_out_mb'] / r['size_in_mb']:>7.2f}"
        f"{r['prusaslicer_cpu_s']:>8.1f}{r['first_cpu_s']:>8.1f}{r['repeat_cpu_s']:>8.1f}",
        flush=True,
    )


def _targets(rows: list[dict]) -> list[str]:
    lines = []

    def verdict(ok: bool) -> str:
        return "met" if ok else "MISSED"

    for r in rows:
        s = r["prusaslicer_s"]
        f, p = r["first_s"] / s, r["repeat_s"] / s
        lines.append(
            f"{r['part']}: first run {f:.1f}x <= 3x {verdict(f <= 3)}; "
            f"repeated {p:.1f}x <= 1.5x {verdict(p <= 1.5)}"
        )
        if r["part"] in SOLID_PARTS:
            o = r["size_out_mb"] / r["size_in_mb"]
            lines.append(f"{r['part']}: output {o:.2f}x the input <= 1.5x {verdict(o <= 1.5)}")
        if r["part"] == "specimen-1000":
            lines.append(
                f"{r['part']}: {r['first_s']:.1f} s < 15 s {verdict(r['first_s'] < 15)}; "
                f"peak {r['peak_rss_mb']:.0f} MB < 1024 MB {verdict(r['peak_rss_mb'] < 1024)}"
            )
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, nargs="?", default=None, help="folder for bench_latency.json")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="one repeat; example, 100 layers, gyroid gusset")
    from loadpath.engines import NAMES
    ap.add_argument("--engine", default=None, choices=tuple(NAMES),
                    help="pass --engine NAME to every run (default: none, the product's own engines)")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds before a run is given up")
    ap.add_argument("--only", default=None, help="comma-separated part names")
    args, _ = ap.parse_known_args(argv)
    repeats = 1 if args.quick else max(1, args.repeats)
    eng = ["--engine", args.engine] if args.engine else []
    head = (
        f"{'part':<24}{'layers':>7}{'slice s':>9}{'first s':>9}{'x':>7}{'repeat s':>9}{'x':>7}"
        f"{'peak MB':>9}{'in MB':>8}{'out/in':>7}{'cpu:sl':>8}{'first':>8}{'repeat':>8}"
    )
    rows: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="bench_latency_") as tmp:
        folder = Path(tmp)
        ohs = slicing.write_stl(slicing.ohs_mesh(), folder / "ohs.stl")
        gusset = slicing.write_stl(gusset_mesh(), folder / "gusset.stl")
        parts = [
            ("example", ohs, slicing.PRUSA_EXAMPLE, eng, REPO / "examples" / "ohs.gcode"),
            ("specimen-100", None, slicing.PRUSA_EXAMPLE, eng, None),
            ("gusset-gyroid30", gusset, GUSSET, eng, None),
            ("gusset-gyroid30-sparse", gusset, GUSSET, [*eng, "--replace", "solid,sparse"], None),
            ("gusset-100", gusset, GUSSET_SOLID, eng, None),
            ("specimen-1000", None, slicing.PRUSA_EXAMPLE, eng, None),
        ]
        if args.quick:
            parts = [p for p in parts if p[0] in ("example", "specimen-100", "gusset-gyroid30")]
        if args.only:
            keep = set(args.only.split(","))
            parts = [p for p in parts if p[0] in keep]
        start = statistics.median(_child([LOADPATH, "--help"])[0] for _ in range(repeats))
        print(
            f"loadpath run vs PrusaSlicer slicing, whole processes, median of {repeats}; engine "
            f"{args.engine or 'default'}; {slicing.prusa_version()}; interpreter + imports (loadpath --help) "
            f"{start:.2f} s; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores",
            flush=True,
        )
        print(head)
        print("-" * len(head), flush=True)
        for name, stl, settings, extra, given in parts:
            if stl is None:
                h = {"specimen-100": 20.0, "specimen-1000": 200.0}[name]
                stl = slicing.write_stl(slicing.ohs_mesh(thickness=h), folder / f"{name}.stl")
            rows.append(bench(name, stl, settings, folder, repeats, extra, args.timeout, given))
            _show(rows[-1])
    print("\ntargets (issue 17):")
    for line in _targets(rows):
        print("  " + line)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "bench_latency.json").write_text(json.dumps({"start_s": start, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
