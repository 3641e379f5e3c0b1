"""The lane kernel templates' globals: compile-time flags and bound helpers.

The templates of ``kernel_vector.py``, ``kernel_events.py``,
``kernel_modes.py`` and ``kernel_tiles.py`` read these names as globals (each
module star-imports this one); ``kernel.build_kernel`` replaces them per
variant through ``jit.specialise`` (``KernelVariant.constants`` and the bound
templates), so a scene compiles only the branches it uses.  The values here
are the defaults a template module is imported with, in one place.
"""

from __future__ import annotations

from .layout import N_SUBSTEPS

# bound per scene by kernel.build_kernel (compile-time constants)
step = ramp_height = ramp_slope_curvature = None
ONE_SIDED = True  # block on top of the ramp (lift-off) rather than a bead on a wire
CHECK_CONTACT = True  # False where n > 0 is known in advance (f'' >= 0)
CARRY_SLOPE = True  # keep f', f'' from the previous step end rather than re-evaluate
LANES = 64  # lanes per block
ADAPTIVE = False  # an embedded pair with per-lane step sizes (adaptive.py)
SUBSTEPS = N_SUBSTEPS  # (attempted) steps between scalar passes
CHAINS = 2  # lane-loop halves run side by side (1: one after the other)
UNROLL = 1  # fixed steps per lane visit, state held in registers
PAPER_CRITERION = False  # record where the paper's eq. (26) would report lift-off
FRICTION = True  # False: mu_k = 0 everywhere, no friction branch (see kernel.build_kernel)
# Known in advance for some methods and ramps (see kernel.build_kernel):
WORK_SIGN_CHECK = True  # False: each step's friction work is >= 0 by construction
CONSTANT_CURVATURE = False  # f'' is the same all along the ramp: no curvature integral
LINEAR_EVENTS = False  # x and v are linear in the step size: events in closed form
MONOTONE_STEP = False  # a step that keeps d v > 0 moves x in direction d (first-order methods)
UNIFORM_PARAMETERS = False  # g and the ramp parameters are the run's settings, not per lane
DRAG_LINEAR = DRAG_QUADRATIC = DRAG = False  # air drag's terms (DRAG: either)
# f', f'' at a step's end from those at its start (the family's stage
# evaluation, steppers.ramp_slope_curvature_near), where it has one
STAGE_FROM_START = False
ramp_slope_curvature_near = None
# fixed steps: fields per history bank (x, v, W, then WD where the kernel
# has it; no K: the curvature integral is formed per mode, kernel_modes._mode_curvature)
# and where WD sits in a bank (see kernel.build_kernel)
N_HIST = 4
HIST_WD = 3
# fixed steps with a split step (RK4: steppers.FixedStepMethod.split): the
# vector loop runs the step's first part for all lanes, then its last part,
# the values between them in N_CARRY fields from CARRY (after the history
# banks; see kernel.build_kernel)
SPLIT_STEP = False
CARRY = 0
N_CARRY = 8
first_stages = last_stages = None
(advance_lanes, load_lane, resolve_lane, finish_lane, event_value, locate_event, apply_step,
 run_tile, current_time, rebase, make_empty, set_mode, start_value, fill_lane,
 scan_lanes, compact_lanes, event_values, refresh_slope, active_span,
 trial_step, apply_event, start_adaptive, new_lanes, fixed_step_lane, paper_scan,
 resolve_linear, take_event, step_and_check, start_block, replay_lane,
 attempt_once, lane_parameters, uniform_parameters, locate_earliest,
 runtime_flags, clean_steps, step_from_bank, restore_bank, first_stages_lane,
 checked_step, mode_curvature) = (None,) * 41
