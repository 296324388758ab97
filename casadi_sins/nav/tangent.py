"""The strapdown step from raw pulse sums, with its forward derivative: the estimator's chain.

The estimator (:mod:`calibrate.nlp.graph`) navigates each group by steps of summed raw pulses,
compensated with the parameters (:func:`model.output.compensate_expr`, with the extra groups'
corrections of the gyro and accelerometer increments) and stepped by the one strapdown step (:func:`nav.strapdown.step_expr`).  Its Jacobian
comes from the step's forward derivative carried along the chain: with ``X`` the state's derivative
along the ``nd`` directions (the parameters in natural units, then the group's start-attitude
rotation)::

    x_k = f(x_(k-1), p, data_k),    X_k = df/dx X_(k-1) + df/dp diag(s)

one call per step, instead of a symbolic Jacobian of the whole graph.  Both steps are packed for a
chain of compiled blocks (:mod:`core.compiled`)::

    const = (21 parameters, their natural scales s, the extra terms, their scales, Earth rate, gravity)
    data  = (gyro pulse sums (3), accelerometer pulse sums (3), step length, previous-step flag,
             the regressor rows the extra groups read, :mod:`model.regressors`)
"""

from __future__ import annotations

import functools

import casadi as ca

from ..core.compiled import block_of, cached_functions
from ..model.output import compensate_expr
from ..model.registry import N_PARAMS, groups_in, regressor_blocks
from ..model.regressors import size as regressor_rows
from .strapdown import STATE_SIZE, step_expr

#: Steps per compiled block of the estimator's chains (a group is padded to a multiple with steps after its end).
STEP_BLOCK = 100


def packed_sizes(names) -> tuple[int, int]:
    """Lengths of the packed ``const`` and ``data`` of a step of the parameter model ``names``."""
    extras = len(names) - N_PARAMS
    return 2 * N_PARAMS + 2 * extras + 4, 8 + regressor_rows(regressor_blocks(names))


def model_tag(names) -> str:
    """A short name of a parameter model: ``"21"`` or its extra groups."""
    return "_".join(groups_in(names)) or "21"


def _increments(names, const, data):
    """The compensated increments of a step, and the pieces of the packed inputs."""
    extras = len(names) - N_PARAMS
    n_const = const.numel()
    params, extra_values = const[:N_PARAMS], const[2 * N_PARAMS:2 * N_PARAMS + extras]
    extra = (extra_values, names[N_PARAMS:], data[8:]) if extras else None
    dtheta, dv = compensate_expr(data[0:3], data[3:6], params, data[6], extra)
    earth, gravity = const[n_const - 4:n_const - 1], const[n_const - 1]
    return dtheta, dv, earth * data[6], ca.vertcat(0, 0, -gravity * data[6]), data[7]


def pulse_step_function(names) -> ca.Function:
    """The nominal step from raw pulse sums: ``(x, const, data) -> (x_next, const)``."""
    n_const, n_data = packed_sizes(names)
    x, const, data = ca.SX.sym("x", STATE_SIZE), ca.SX.sym("const", n_const), ca.SX.sym("data", n_data)
    x_next = step_expr(x, *_increments(names, const, data))
    return ca.Function(f"pulse_step_{model_tag(names)}", [x, const, data], [x_next, const],
                       ["x", "const", "data"], ["x_next", "const_next"])


def tangent_step_function(names) -> ca.Function:
    """The step with its forward derivative along the ``nd = len(names) + 3`` directions (module docstring)::

        (xX (13 x (1 + nd)), const, data) -> (xX_next, const)

    Column 0 is the state, column ``1 + i`` its derivative along direction ``i``.
    """
    extras = len(names) - N_PARAMS
    nd = len(names) + 3
    n_const, n_data = packed_sizes(names)
    x_all, const, data = ca.SX.sym("xX", STATE_SIZE, 1 + nd), ca.SX.sym("const", n_const), ca.SX.sym("data", n_data)
    x, tangents = x_all[:, 0], x_all[:, 1:]
    x_next = step_expr(x, *_increments(names, const, data))
    params, scales = const[:N_PARAMS], const[N_PARAMS:2 * N_PARAMS]
    inputs = [x, params]
    seeds = [tangents, ca.horzcat(ca.diag(scales), ca.SX(N_PARAMS, nd - N_PARAMS))]
    if extras:
        inputs.append(const[2 * N_PARAMS:2 * N_PARAMS + extras])
        seeds.append(ca.horzcat(ca.SX(extras, N_PARAMS), ca.diag(const[2 * N_PARAMS + extras:2 * N_PARAMS + 2 * extras]),
                                ca.SX(extras, 3)))
    tangents_next = ca.jtimes(x_next, ca.vertcat(*inputs), ca.vertcat(*seeds))
    return ca.Function(f"tangent_step_{model_tag(names)}", [x_all, const, data], [ca.horzcat(x_next, tangents_next),
                       const], ["xX", "const", "data"], ["xX_next", "const_next"])


@functools.lru_cache(maxsize=None)
def step_blocks(names: tuple[str, ...], compiled: bool = True) -> tuple[ca.Function, ca.Function]:
    """``(tangent block, nominal block)`` of a parameter model: :data:`STEP_BLOCK` steps each, compiled
    (:func:`core.compiled.cached_functions`) unless ``compiled`` is false; ``(x, const, data (d x
    STEP_BLOCK)) -> (x_last, const, every state)``."""
    tag = model_tag(names)
    block_names = [f"tangent_block_{tag}", f"pulse_block_{tag}"]

    def build():
        return [block_of(tangent_step_function(names), STEP_BLOCK, block_names[0]),
                block_of(pulse_step_function(names), STEP_BLOCK, block_names[1])]

    if not compiled:
        return tuple(build())
    return tuple(cached_functions(f"steps_{tag}", repr((names, STEP_BLOCK)), block_names, build))
