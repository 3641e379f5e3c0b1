"""Where things live in the lane kernels' flat arrays (shared by the
fixed-step kernel of ``kernel.py`` and the adaptive one in ``adaptive.py``)."""

# --- lane state: one flat float64 array, field F of lane i at F * LANES + i ----
# T, XM, SM: time, position and step count at the start of the current mode
# (time and path are derived from them, which keeps the hot loop lean);
# LIMIT: step count at which t_max would be passed;
# CASCADE: events resolved since the lane last took a full step; VLIM2, ELIM:
# the divergence bounds on v^2 and on the mechanical energy.
# Adaptive methods only: H, the lane's next step size; LERR, log2 of the last
# accepted error norm (the PI term); REJ, 1 if the last attempt was rejected;
# NREJ, rejected attempts; A1, the acceleration at the current state (first
# stage, carried over from the last stage); EEST, the sum of the accepted
# steps' error estimates of the friction work; PENDING, 1 while the lane's
# step holds an event (or its step size collapsed); T is then the current time.
# The paper's lift-off criterion (a diagnostic, when asked for): XP, the x
# where it first held (NaN before); PXM, the x up to which it has been checked.
# FRESH: 1 from a two-sided contact switch until the next accepted step.
# EPROJ (adaptive pairs with the energy projection): the sum of the energy
# residuals the projection removed (adaptive._project_energy), per unit mass.
# Air drag (kernels built with drag only): DRAG_B, DRAG_C, the coefficients b
# (1/s) and c (1/m); WD, the work against drag per unit mass.
# Fixed-step methods only: CLEAN, 1.0 while every step of the current block
# of SUBSTEPS has been clean (no event condition fired), 0.0 after one was
# not; the vector loop does not stop a lane at its event but steps on, and
# keeps each step's state in the history banks (HIST below), from which the
# scan takes the state at the start of the first step that was not clean.
# Adaptive methods only:
# BLOCK_STEPS, the step count at the block's start (a lane that stepped since
# has made progress: its event cascade count restarts).  Fixed-step methods
# only, set with the mode: DSIGN, the sign bit of D as a float (-0.0 or 0.0),
# so that the vector loop tests d v > 0 with a bit flip instead of a
# multiplication; QH, q times the step (the first product of the friction
# work's h q n v); AHEAD, the end of the domain ahead (x_hi for d > 0,
# x_lo for d < 0), the only one a first-order step can cross.  These take
# work off the multiply and compare pipes, the vector loop's bottleneck for
# the first-order methods.
# The first N_BANKED fields are the state an adaptive attempt may or may not
# commit.  They have a second bank, fields BANK_B .. BANK_B + N_BANKED - 1:
# attempts alternate reading one bank and writing the other (see
# adaptive._advance_lanes_adaptive), so every store is unconditional.
(X, V, FP, FPP, W, K, WD, A1, T, H, LERR, REJ, FRESH,
 Q, D, SN, S, XM, SM, LIMIT, G, VLIM2, P0, P1, P2, P3,
 STEPS, CLEAN, TRAJ, NREV, MUK, MUS, E0, FPP0, CASCADE, ELIM,
 NREJ, EEST, PENDING, DRAG_B, DRAG_C, XP, PXM,
 BLOCK_STEPS, DSIGN, QH, AHEAD, EPROJ) = range(48)
N_FIELDS = 48
# Fixed-step kernels: after the N_FIELDS fields, the history banks.  Bank j
# (0 .. SUBSTEPS) holds the state after step j of the block (bank 0: its
# start): x, v and the integrals W, WD at fields HIST + N_HIST j + HIST_X
# .. HIST_WD, where a kernel has WD (kernel.build_kernel sets N_HIST and its
# place; no K: fixed steps form the curvature integral per mode).  Kernels
# whose step runs in two lane loops (RK4: kernel_globals.SPLIT_STEP) have,
# after the banks, kernel_globals.N_CARRY fields for the values passed from
# the first loop to the second.
HIST = N_FIELDS
HIST_X, HIST_V, HIST_W = range(3)
N_BANKED = 13
BANK_B = N_FIELDS  # field F's bank-B copy is F + BANK_B (F < N_BANKED)
N_LANE_FIELDS = N_FIELDS + N_BANKED  # adaptive kernels; fixed-step ones: the history banks instead
# After the lanes (N_LANE_FIELDS * LANES; (N_FIELDS + N_HIST SUBSTEPS) * LANES
# in fixed-step kernels), a tile's scratch: the height range of the ramp parameters
# last loaded (RANGE_P0..P3 -> RANGE_FMIN, RANGE_FMAX), so that a sweep whose
# ramp does not change samples it once per tile, not once per trajectory.
RANGE_P0, RANGE_P1, RANGE_P2, RANGE_P3, RANGE_FMIN, RANGE_FMAX = range(6)
N_SCRATCH = 6

# --- per-trajectory inputs: rows of a float64 array (N_INPUTS, N) --------------
# IN_DRAG_B, IN_DRAG_C: air drag's linear (1/s) and quadratic (1/m) coefficients
# (read only by kernels built with drag; 0 otherwise)
IN_X0, IN_V0, IN_MUK, IN_MUS, IN_G, IN_P0, IN_P1, IN_P2, IN_P3, IN_DRAG_B, IN_DRAG_C = range(11)
N_INPUTS = 11

# --- per-trajectory outputs (per unit mass): rows of float64 (N_OUTPUTS, N) ----
# OUT_DRAG_WORK: work against air drag (0 from kernels built without drag)
# OUT_PROJECTED: the energy residuals removed by the adaptive pairs' energy
# projection, summed (0 without it): part of energy_balance_error
(OUT_STATUS, OUT_T, OUT_X, OUT_V, OUT_WORK, OUT_ENERGY_LOSS, OUT_PATH,
 OUT_CONVEXITY, OUT_NREV, OUT_XLIFT, OUT_STEPS, OUT_NREJ, OUT_WORK_ERROR,
 OUT_DRAG_WORK, OUT_XLIFT_PAPER, OUT_PROJECTED) = range(16)
N_OUTPUTS = 16

# --- scalar settings: float64 array ---------------------------------------------
# SET_DT: the fixed step, or an adaptive method's first step (0: estimate it);
# SET_HMAX, SET_HMIN: an adaptive method's largest step and the size below
# which a collapsing step counts as divergence
# SET_G, SET_P0..SET_P3: g and the ramp parameters where no trajectory of the
# run has others (read by kernels built with uniform_parameters)
(SET_XLO, SET_XHI, SET_DT, SET_TMAX, SET_RTOL, SET_ATOL, SET_HMAX, SET_HMIN,
 SET_G, SET_P0, SET_P1, SET_P2, SET_P3) = range(13)
N_SETTINGS = 13

# --- event kinds ----------------------------------------------------------------
EV_NONE, EV_DIVERGED, EV_EXIT_LO, EV_EXIT_HI, EV_CONTACT, EV_REVERSAL, EV_TIMEOUT = range(7)

#: steps between scalar passes over the lanes (fixed-step methods), and attempted
#: steps between them for adaptive methods: a lane whose step holds an event
#: waits for the next pass, so fewer, costlier steps want more frequent passes
N_SUBSTEPS = 16
N_SUBSTEPS_ADAPTIVE = 4
#: lanes per block: the adaptive pairs' and the general kernels'
DEFAULT_LANES = 64
#: lanes per block of the specialised fixed-step kernels (KernelVariant's
#: default for them; DEFAULT_LANES elsewhere): a lane loop with two
#: chains steps every lane of the block, busy or not, so a tile's tail (its
#: last, longest trajectories) steps half as many empty lanes as with 64;
#: measured equal on identical trajectories, faster on the grid of
#: benchmarks/families.py (with runner.tile_size's one tile per thread,
#: 1.08-1.16x; benchmarks/README.md, vmath/families, sixth pass)
FIXED_STEP_LANES = 32
#: lanes per iteration of the vectorised loop (8 float64 in 512 bits, two
#: iterations interleaved): the tail of a tile steps whole blocks of this many
VECTOR_BLOCK = 16
#: samples of f over the domain used for the divergence speed bound
N_RANGE_SAMPLES = 33
#: divergence inside a step: speed above this multiple of the energy bound
SPEED_BOUND_FACTOR = 10.0
#: divergence at the end: mechanical energy risen by more than this
#: share of the energy scale (start kinetic energy plus the ramp's height range
#: times g).  Friction, drag and a fixed ramp can only remove energy, so only a
#: step far too large gets there (explicit Euler's energy grows every step).
ENERGY_RISE_FACTOR = 0.5
#: divergence: this many events in a row without a full step between them.
#: With a step far too large the stages sample garbage, and "events" can be
#: found again and again a sliver into each step: progress stalls.
MAX_EVENT_CASCADE = 100

