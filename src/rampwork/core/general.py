"""The general kernel: the same templates, with the scene's choices read at run time.

A specialised kernel (``kernel.build_kernel`` of a scene's variant) freezes
every choice of the scene: it is as fast as a kernel written by hand, but
each new choice costs a compilation.  The general kernel of a kind (fixed
steps, or one adaptive pair) is compiled once per machine and serves every
scene of that kind: the ramp family and the fixed-step method are chosen by
ids at the head of the ``shared`` array, and the physics choices of
:data:`RUNTIME_FLAGS` are read from the lane array.

It is built from the very same templates, so a trajectory sees the same
floating-point operations as in the specialised kernel: results are equal
(to the sign of a zero, as a kernel without its friction branch).  A flag
read by a template that has the lane array becomes a load of its run-time
value; a template without it (the steppers, the step test) is compiled with
the flag's :data:`MAXIMAL` value, which computes terms that are zero where
the scene has no such effect (drag with b = c = 0, friction with mu_k = 0)
or a test that cannot fail (the contact check where n > 0 is known).
"""

from __future__ import annotations

import ast
import inspect
import textwrap
import types

import numpy as np

from .jit import specialise
from .ramps import SLOPE_CURVATURE_NEAR, SLOPE_CURVATURE_SHORT

#: the choices a general kernel reads at run time, in the order of their
#: slots (``settings[SET_RUNTIME + k]``, copied into the lane array)
RUNTIME_FLAGS = ("ONE_SIDED", "CHECK_CONTACT", "PAPER_CRITERION", "CONSTANT_CURVATURE",
                 "LINEAR_EVENTS", "DRAG", "DRAG_LINEAR", "DRAG_QUADRATIC", "PROJECT_ENERGY")
#: compile-time values of the general kernel: what every scene may need
#: (pruning that changes no result is left out: f', f'' carried, every check on)
MAXIMAL = {"ONE_SIDED": True, "CHECK_CONTACT": True, "PAPER_CRITERION": True,
           "CONSTANT_CURVATURE": False, "LINEAR_EVENTS": False, "DRAG": True,
           "DRAG_LINEAR": True, "DRAG_QUADRATIC": True, "CARRY_SLOPE": True,
           "WORK_SIGN_CHECK": True, "MONOTONE_STEP": False, "UNIFORM_PARAMETERS": False,
           "FRICTION": True, "PROJECT_ENERGY": True}
#: flags a template without the lane array may not read: their maximal value
#: would change its results
LANES_ONLY = ("ONE_SIDED", "PAPER_CRITERION", "CONSTANT_CURVATURE", "LINEAR_EVENTS")
#: slots at the head of ``shared``: the family id, the fixed-step method id and
#: whether the plan bounds every step's angle (``KernelVariant.short_stages``)
SHARED_HEADER = 3
#: most ramp families a general kernel switches between
MAX_FAMILIES = 8


def runtime_values(variant) -> np.ndarray:
    """The :data:`RUNTIME_FLAGS` of a specialised variant, as floats."""
    constants = variant.constants()
    return np.array([float(constants.get(name, False)) for name in RUNTIME_FLAGS])


class _ReadAtRunTime(ast.NodeTransformer):
    """``FLAG`` -> ``(lanes[RUNTIME_BASE + k] != 0.0)`` for the runtime flags."""

    def visit_Name(self, node):
        if isinstance(node.ctx, ast.Load) and node.id in RUNTIME_FLAGS:
            slot = ast.BinOp(ast.Name("RUNTIME_BASE", ast.Load()), ast.Add(),
                             ast.Constant(RUNTIME_FLAGS.index(node.id)))
            load = ast.Subscript(ast.Name("lanes", ast.Load()), slot, ast.Load())
            return ast.copy_location(
                ast.Compare(load, [ast.NotEq()], [ast.Constant(0.0)]), node)
        return node


def read_at_run_time(template):
    """``template`` with its runtime flags read from the lane array where it
    has one (a new function over the template's module globals; the same
    source file and lines, so numba caches and reports it as the template)."""
    code = template.__code__
    names = set(code.co_names) & set(RUNTIME_FLAGS)
    if not names:
        return template
    if "lanes" not in code.co_varnames[:code.co_argcount]:
        bad = sorted(names & set(LANES_ONLY))
        if bad:
            raise ValueError(f"{template.__name__} reads {', '.join(bad)} without the lane array")
        return template  # compiled with the MAXIMAL values
    tree = ast.parse(textwrap.dedent(inspect.getsource(template)))
    ast.increment_lineno(tree, code.co_firstlineno - 1)
    tree = ast.fix_missing_locations(_ReadAtRunTime().visit(tree))
    namespace: dict = {}
    exec(compile(tree, code.co_filename, "exec"), template.__globals__, namespace)
    function = namespace[template.__name__]
    return types.FunctionType(function.__code__, template.__globals__, template.__name__,
                              template.__defaults__, template.__closure__)


def _copy_runtime_flags(lanes, settings):
    """The general kernel's runtime flags into the lane array (after new_lanes)."""
    for k in range(N_RUNTIME):
        lanes[RUNTIME_BASE + k] = settings[SET_RUNTIME + k]


def _no_runtime_flags(lanes, settings):
    """Specialised kernels have none."""


# The switches over families and methods: the bound FAMILY_k and STEP_k are
# globals (unused family slots repeat family 0), the ids come first in
# ``shared``.  One template serves f and (f', f''): it is bound twice.
def _switch_family(x, p0, p1, p2, p3, shared):
    family = shared[0]
    data = shared[SHARED_HEADER:]
    if family == 0.0:
        return FAMILY_0(x, p0, p1, p2, p3, data)
    if family == 1.0:
        return FAMILY_1(x, p0, p1, p2, p3, data)
    if family == 2.0:
        return FAMILY_2(x, p0, p1, p2, p3, data)
    if family == 3.0:
        return FAMILY_3(x, p0, p1, p2, p3, data)
    if family == 4.0:
        return FAMILY_4(x, p0, p1, p2, p3, data)
    if family == 5.0:
        return FAMILY_5(x, p0, p1, p2, p3, data)
    if family == 6.0:
        return FAMILY_6(x, p0, p1, p2, p3, data)
    return FAMILY_7(x, p0, p1, p2, p3, data)


def _switch_step(x, v, fp, fpp, q, qh, d, h, g, p0, p1, p2, p3, shared, drag_b, drag_c):
    method = shared[1]
    if method == 0.0:
        return STEP_0(x, v, fp, fpp, q, qh, d, h, g, p0, p1, p2, p3, shared, drag_b, drag_c)
    if method == 1.0:
        return STEP_1(x, v, fp, fpp, q, qh, d, h, g, p0, p1, p2, p3, shared, drag_b, drag_c)
    return STEP_2(x, v, fp, fpp, q, qh, d, h, g, p0, p1, p2, p3, shared, drag_b, drag_c)


def build_switches(families, *, cache: bool = True):
    """``(height, slope_curvature, slope_curvature_near)`` switching by
    ``shared[0]`` between ``families``, a sequence of ``(key, height,
    slope_curvature)`` (family k has id k; at most :data:`MAX_FAMILIES`).
    ``slope_curvature_near`` is the evaluation at a step's stage points and
    end from its start (``steppers.ramp_slope_curvature_near``): the
    family's own where it has one (``ramps.SLOPE_CURVATURE_NEAR``, or its
    short form ``ramps.SLOPE_CURVATURE_SHORT`` where ``shared[2]`` says the
    plan chose it), so that the general kernel rounds as the specialised
    one, else its f', f'' evaluated afresh; it is registered as the slope
    switch's."""
    families = tuple(families)
    if not 0 < len(families) <= MAX_FAMILIES:
        raise ValueError(f"a general kernel switches between 1 to {MAX_FAMILIES} families, "
                         f"got {len(families)}")
    padded = families + families[:1] * (MAX_FAMILIES - len(families))
    name = "_".join(key for key, *_ in families)
    internal = {"internal": True, "refcount": False}
    switches = []
    for part, label in ((1, "height"), (2, "slope_curvature")):
        constants = {"SHARED_HEADER": SHARED_HEADER,
                     **{f"FAMILY_{k}": family[part] for k, family in enumerate(padded)}}
        switches.append(specialise(_switch_family, f"switch_{label}_{name}", constants,
                                   cache=cache, **internal))
    near = {}
    for k, (key, _, slope_curvature) in enumerate(padded):
        if slope_curvature in SLOPE_CURVATURE_NEAR:
            near[f"FAMILY_{k}"] = specialise(
                _stage_kind, f"stage_kind_{key}",
                {"SHARED_HEADER": SHARED_HEADER, "NEAR": SLOPE_CURVATURE_NEAR[slope_curvature],
                 "SHORT": SLOPE_CURVATURE_SHORT.get(slope_curvature,
                                                    SLOPE_CURVATURE_NEAR[slope_curvature])},
                cache=cache, **internal)
        else:
            near[f"FAMILY_{k}"] = specialise(
                _near_afresh, f"near_afresh_{key}",
                {"SHARED_HEADER": SHARED_HEADER, "SLOPE_CURVATURE": slope_curvature},
                cache=cache, **internal)
    SLOPE_CURVATURE_NEAR[switches[1]] = specialise(
        _switch_near, f"switch_near_{name}", {"SHARED_HEADER": SHARED_HEADER, **near},
        cache=cache, **internal)
    return tuple(switches)


SLOPE_CURVATURE = None  # bound by build_switches


def _near_afresh(x, dx, fp, fpp, p0, p1, p2, p3, shared):
    """A family's f', f'' at a stage point, evaluated afresh."""
    return SLOPE_CURVATURE(x, p0, p1, p2, p3, shared[SHARED_HEADER:])


def _stage_kind(x, dx, fp, fpp, p0, p1, p2, p3, shared):
    """A family's own stage evaluation, in the form the plan chose
    (shared[2]: the short form, ``KernelVariant.short_stages``)."""
    data = shared[SHARED_HEADER:]
    if shared[2] != 0.0:
        return SHORT(x, dx, fp, fpp, p0, p1, p2, p3, data)
    return NEAR(x, dx, fp, fpp, p0, p1, p2, p3, data)


# the whole ``shared`` to the family's entry (the stage kind is in its header)
def _switch_near(x, dx, fp, fpp, p0, p1, p2, p3, shared):
    family = shared[0]
    if family == 0.0:
        return FAMILY_0(x, dx, fp, fpp, p0, p1, p2, p3, shared)
    if family == 1.0:
        return FAMILY_1(x, dx, fp, fpp, p0, p1, p2, p3, shared)
    if family == 2.0:
        return FAMILY_2(x, dx, fp, fpp, p0, p1, p2, p3, shared)
    if family == 3.0:
        return FAMILY_3(x, dx, fp, fpp, p0, p1, p2, p3, shared)
    if family == 4.0:
        return FAMILY_4(x, dx, fp, fpp, p0, p1, p2, p3, shared)
    if family == 5.0:
        return FAMILY_5(x, dx, fp, fpp, p0, p1, p2, p3, shared)
    if family == 6.0:
        return FAMILY_6(x, dx, fp, fpp, p0, p1, p2, p3, shared)
    return FAMILY_7(x, dx, fp, fpp, p0, p1, p2, p3, shared)


def shared_header(family_id: int, method_id: int, short_stages: bool = False) -> np.ndarray:
    """The head of a general kernel's ``shared`` array (then the family's own)."""
    return np.array([float(family_id), float(method_id), float(short_stages)])


# bound by the builders
N_RUNTIME = len(RUNTIME_FLAGS)
RUNTIME_BASE = SET_RUNTIME = 0
(FAMILY_0, FAMILY_1, FAMILY_2, FAMILY_3, FAMILY_4, FAMILY_5, FAMILY_6, FAMILY_7,
 STEP_0, STEP_1, STEP_2, SHORT, NEAR) = (None,) * 13
