"""Integer status codes of a trajectory (jit-friendly plain ints).

Stored in datasets as ``status`` with CF ``flag_values``/``flag_meanings``.
"""

NOT_RUN = 0  # placeholder for trajectories not computed yet (resumable sweeps)
STUCK = 1  # came to rest where static friction holds it: |f'(x)| <= mu_s
EXITED = 2  # reached x_min or x_max of the domain
LIFTED_OFF = 3  # one-sided contact: normal term n = g + v^2 f'' reached 0
TIMEOUT = 4  # t_max reached while still moving
DIVERGED = 5  # state not finite, speed beyond the energy bound, or event not located

#: (code, name, meaning) in code order
STATUS_TABLE = (
    (NOT_RUN, "not_run", "trajectory not computed (yet)"),
    (STUCK, "stuck", "came to rest and static friction holds it (|f'| <= mu_s)"),
    (EXITED, "exited", "reached an end of the ramp's domain"),
    (LIFTED_OFF, "lifted_off", "left a one-sided ramp where the normal force reached zero"),
    (TIMEOUT, "timeout", "still moving at t_max"),
    (DIVERGED, "diverged", "state stopped being finite or exceeded the energy bound: step too large"),
)

STATUS_NAMES = {code: name for code, name, _ in STATUS_TABLE}
