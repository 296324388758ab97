"""``calibrate_nlp``: calibration as one nonlinear least-squares problem, as a pipeline of named stages.

1. :func:`_prepare`: observation spacing, the parameter model, the noise plan (raw data, datasheet),
   base motion.
2. :func:`_observable_graph`: the symbolic graph (:mod:`.graph`); extra groups the schedule cannot
   see are left at their prior, with a warning; ``model="extended"`` or ``"auto"`` also leaves out those it
   cannot separate from one of the 21 (:func:`_separable_graph`), with a note.
3. :func:`_fit_model`: Ipopt and the generalised least squares (:mod:`.gls`); the velocity steps
   across rotations are dropped when they disagree with the static residuals; ``model="auto"``
   keeps the extra groups the data support (:mod:`.selection`).
   :func:`_bias_wander`: without a datasheet's bias instability, the wander the static data show
   (:mod:`.wander`); an included term enters the noise model and the solve is repeated under it.
   A misfit of a 21-parameter fit is first tried on the extra groups (:func:`_evidence`, :mod:`.evidence`):
   a group that explains it is named with ``--model auto`` as the remedy, and no wander is blamed.
4. :func:`_assess`: the checks (:mod:`.diagnostics`); when the residuals exceed the noise model, the
   errors outside it are estimated (:mod:`.likelihood`) and the solve is repeated with them.
5. :func:`_result`: the parameter table, its covariance and the report's contents.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable

import numpy as np

from ...core.rotations import rotation_matrices
from ...core.units import ARCSEC, DEG_PER_H, UG
from ...data.recording import Recording
from ...model.noise import SensorNoise
from ...model.parameters import ParameterSet
from ...model.registry import GROUPS, N_PARAMS, groups_in, model_names
from ...noise.motion import describe_motion, sway_treatment
from ...noise.plan import NoisePlan, plan_noise
from ..initial import resolves_earth_rate, rough_parameters
from ..limits import SCHEDULE_REMEDY, grade_levels, separation_warnings
from ..result import CalibrationResult, NlpDetails, NoiseReport, outcome
from ..steps import ROTATION_STEP_S, SWAY_STATIC_STEP_S, default_observation_spacing
from ..wander import bias_cost, describe, natural_size, record, with_wander
from .base import EXTRA_SEQUENCES
from .diagnostics import STEP_CONSISTENCY_LIMIT, Assessment, assess
from .evidence import candidate_groups, evidence_note, evidence_warning, group_evidence, is_21
from .gls import Fit, fit_graph, generalised_least_squares
from .graph import ResidualGraph, build_graph, natural_to_parameters, variable_scale
from .ipopt import MOVING_OBJECTIVE_CHANGE, quick_weights
from .likelihood import estimate_unmodelled, unmodelled_at_bounds
from .selection import inseparable_group, model_groups, model_label, select_groups, unobservable_group
from .start import RELINEARISE_NOISE, presolve, start_vector
from .wander import estimate_bias_wander

#: The navigation step (s) of a MEMS unit moved by hand, in its moves and its rests (see ``static_step_s``).
HAND_STEP_S = 0.02
#: The default model of a MEMS unit moved by hand: the 21 and the gyro g-sensitivity (a MEMS gyro's is hundreds of
#: deg/h per g; in a rest of seconds it tilts the unit by tenths of a degree).
HAND_MEMS_MODEL = ("gyro_gsens",)

SIGMA_MEANING = ("1-sigma from the Gauss-Newton covariance (J^T W J)^-1 of the velocity and gyro residuals, "
                 "W from the noise model (raw-data estimate, datasheet, fit, bias wander of the static data), times the variance factor when "
                 "the residuals exceed the model")


@dataclasses.dataclass
class _Run:
    """What the stages share: the recording, the options, the noise plan and what was decided so far."""

    rec: Recording
    initial: ParameterSet
    noise_plan: NoisePlan
    observe_s: float
    rotation_step_s: float
    static_step_s: float
    groups: tuple[str, ...]
    model: object
    solve: dict
    progress: Callable[[str], None] | None
    warnings: list[str]
    t_start: float
    noise_s: float
    built: list[ResidualGraph] = dataclasses.field(default_factory=list)
    selection: dict | None = None
    wander: dict = dataclasses.field(default_factory=dict)
    evidence: dict | None = None
    evidence_named: bool = False
    notes: list[str] = dataclasses.field(default_factory=list)
    left_out: dict = dataclasses.field(default_factory=dict)
    start: str = "ipopt"  # or "gauss-newton": stage 1 from a start fitted to the data (.start)
    navigation_grade: bool = True  # the gyros resolve the Earth rate (initial.resolves_earth_rate)
    relinearise: float | None = None  # the GLS's noise-model rebuild threshold (sigma), default gls'
    distrust: list[str] = dataclasses.field(default_factory=list)

    def say(self, message: str) -> None:
        if self.progress:
            self.progress(f"nlp: {message}")

    def build(self, names) -> ResidualGraph:
        # the 21 of the start, the extra terms at their prior: the reference the information criterion tests against
        reference = ParameterSet(self.initial.values[:N_PARAMS]).aligned(names)
        tapers = {m.segment: m.taper.nw for m in self.noise_plan.motions if m.taper is not None}
        referenced = {m.segment for m in self.noise_plan.motions if m.taper is not None and m.uses_reference}
        graph = build_graph(self.rec, reference, self.observe_s, self.rotation_step_s,
                            self.static_step_s, names, tapers, base_bands(self.rec, self.noise_plan), referenced)
        self.built.append(graph)
        self.say(f"graph of {sum(len(p.step_dt) for p in graph.groups)} steps, {graph.n_variables} variables "
                 f"({len(names)} parameters), {graph.n_residuals} residuals built in {graph.build_time:.2f} s")
        return graph

    def fit(self, graph: ResidualGraph, use_rotation_steps: bool) -> Fit:
        solve = dict(self.solve)
        presolved, x0 = None, start_vector(graph, self.initial)
        if self.start == "gauss-newton":
            presolved = presolve(self.rec, graph, self.noise_plan, use_rotation_steps, solve["max_iterations"],
                                 self.progress, x0)
            if not presolved[1]["success"]:  # a misfit's flat valley: Ipopt, with its rule for a stalled objective
                self.say("the Gauss-Newton steps did not settle: Ipopt goes on from where they got")
                presolved, x0 = None, presolved[0]
        if solve["max_iterations"] is None:
            solve["max_iterations"] = max(200, 20 * graph.n_variables)
        return fit_graph(self.rec, graph, self.noise_plan, use_rotation_steps, progress=self.progress,
                         presolved=presolved, x0=x0, relinearise=self.relinearise, **solve)


def calibrate_nlp(rec: Recording, initial: ParameterSet | None = None, hessian: str = "gauss-newton",
                  static_block_s: float | None = None, rotation_step_s: float | None = None,
                  use_rotation_steps: bool | str = "auto", tolerance: float = 1e-7, max_iterations: int | None = None,
                  progress: Callable[[str], None] | None = None, noise: SensorNoise | None = None,
                  static_step_s: float | None = None, model=None) -> CalibrationResult:
    """Calibrate a recording by nonlinear least squares over all rotations (CasADi + Ipopt).

    Parameters
    ----------
    rec : Recording
    initial : ParameterSet, optional
        Starting values and reference of the natural-unit variables; default the rough values (extra
        terms: their prior, 0).
    hessian : {"gauss-newton", "exact", "limited-memory"}
        Hessian of Ipopt's stage.
    static_block_s : float, optional
        Seconds between velocity observations in static segments (default
        :func:`steps.default_observation_spacing`).
    rotation_step_s : float, optional
        Rotation step (default 40 ms: a method error below 0.001 natural units on the paper's problem; the
        number of steps, hence the time, does not grow with the sample rate; :data:`HAND_STEP_S` for a MEMS
        unit by hand, below).
    use_rotation_steps : bool or "auto"
        Keep the velocity steps across rotations.  ``"auto"`` keeps them unless they disagree with the
        static residuals (F-test, :data:`diagnostics.STEP_CONSISTENCY_LIMIT`): lever arms or timing offsets
        of a real unit make velocity steps that the 21-parameter model cannot explain.  A session by hand keeps
        them (without them its rests' velocities are free and the accelerometers undetermined): a misfit there
        is an error outside the model.
    tolerance : float
        Ipopt's tolerance on the gradient of the mean square weighted residual (natural units).
    max_iterations : int, optional
        Ipopt's iteration cap; default ``max(200, 20 x variables)`` (3-5 iterations are typical; starts far
        off nominal and unmodelled errors take more, and a cap is only a guard against a run that never
        ends).
    progress : callable, optional
        Receives one line per stage.
    noise : SensorNoise, optional
        Datasheet noise terms; those not given are estimated from the data.
    static_step_s : float, optional
        Navigation step in static segments (default: the observation spacing; on a swaying base
        :data:`steps.SWAY_STATIC_STEP_S`; :data:`HAND_STEP_S` for a MEMS unit by hand: its moves turn at
        hundreds of deg/s about wandering axes and a hand's tremor turns its rests, so that pulses summed over
        40 ms of a move or a second of a rest err by tens of ug and deg/h, measured on noise-free simulations;
        steps of 20 ms with the coning and sculling terms keep it to a few hundredths of that).
    model : {"21", "extended", "auto"}, tuple of group keys, or None
        The parameters: the paper's 21; with every extra group of the registry (quadratic scale, lever arms,
        time offset); or ``"auto"``: the extra groups the data support (each group's Wald statistic in the
        extended fit against the Bayesian information criterion ``k ln n``), refitted with those alone.
        Terms not estimated stay at their prior (0).  None (the default): ``"21"``, and the 21 with the gyro
        g-sensitivity (:data:`HAND_MEMS_MODEL`) for a MEMS unit (gyros that do not resolve the Earth rate,
        :func:`initial.resolves_earth_rate`) moved by hand (rests at any orientation, free moves): its
        g-sensitivity, left out, would bias the 21 far beyond their sigma, and the rests at many orientations
        determine it.

    Raises
    ------
    CalibrationError
        Ipopt fails to converge or the problem is rank deficient.
    """
    run = _prepare(rec, initial, noise, model, static_block_s, static_step_s, rotation_step_s, progress,
                   {"hessian": hessian, "tolerance": tolerance, "max_iterations": max_iterations})
    graph = _observable_graph(run)
    graph, fit = _fit_model(run, graph, use_rotation_steps)
    fit = _bias_wander(run, graph, fit)
    graph_s = sum(g.build_time for g in run.built)
    timings = {"noise from the raw data": run.noise_s, "graph": graph_s,
               "ipopt and generalised least squares": time.perf_counter() - run.t_start - graph_s - run.noise_s}
    fit, assessment = _assess(run, graph, fit)
    timings["checks and covariance"] = time.perf_counter() - run.t_start - sum(timings.values())
    return _result(run, graph, fit, assessment, timings)


def _prepare(rec, initial, noise, model, static_block_s, static_step_s, rotation_step_s, progress, solve) -> _Run:
    """Stage 1: options, the parameter model, the noise plan and the base motion."""
    t_start = time.perf_counter()
    observe_s = default_observation_spacing(rec) if static_block_s is None else static_block_s
    initial = initial or rough_parameters(rec)
    navigation_grade = resolves_earth_rate(rec, initial.values)
    mems_by_hand = any(s.is_free for s in rec.segments) and not navigation_grade
    model = model if model is not None else (HAND_MEMS_MODEL if mems_by_hand else "21")
    if rotation_step_s is None:
        rotation_step_s = min(HAND_STEP_S, ROTATION_STEP_S) if mems_by_hand else ROTATION_STEP_S
    if static_step_s is None and mems_by_hand:
        static_step_s = HAND_STEP_S
    groups = model_groups(model)
    noise_plan = plan_noise(rec, initial.aligned(model_names(groups)), noise)
    noise_s = time.perf_counter() - t_start
    swaying = describe_motion(noise_plan.motions)
    if static_step_s is None:
        static_step_s = min(observe_s, SWAY_STATIC_STEP_S) if swaying else observe_s
    linear = noise_plan.linear.describe() if noise_plan.linear is not None else None
    if swaying or linear:
        solve = dict(solve, objective_change=MOVING_OBJECTIVE_CHANGE)
    run = _Run(rec, initial, noise_plan, observe_s, rotation_step_s, static_step_s, groups, model, solve, progress,
               list(rec.warnings), t_start, noise_s, navigation_grade=navigation_grade)
    if mems_by_hand:
        run.start = "gauss-newton"  # near the answer, and Ipopt's quick weights miss a MEMS unit's tilt walk (.start)
        run.relinearise = RELINEARISE_NOISE  # its heading, weakly determined, would chase its own whitening
    if swaying:
        run.say(f"{swaying}; static segments stepped at {static_step_s:g} s")
    if linear:
        bands = base_bands(rec, noise_plan)
        message = (f"{linear}: the base's velocity is estimated with the parameters, free within "
                   f"{', '.join(f'{low:.3g}-{high:.3g} Hz ({axes})' for low, high, axes in bands)} and constant per "
                   "group (the velocity's information in those bands is given up)")
        run.warnings.append(message)
        run.say(message)
    return run


#: Frequency bins of the whole recording left on either side of a base motion's lines.
BASE_BAND_MARGIN = 2.0


def base_bands(rec: Recording, noise_plan: NoisePlan) -> list[tuple[float, float, str]] | None:
    """The frequency bands (Hz) left to the base's velocity on a moving base, with the ENU axes each moves
    (``None`` on a still one): its lines with :data:`BASE_BAND_MARGIN` frequency bins of the recording on either
    side; bands closer than their signals reach beyond them (:data:`.base.EXTRA_SEQUENCES`) are one band."""
    if noise_plan.linear is None or not noise_plan.linear.moving:
        return None
    bin_hz = 1.0 / float(rec.time[-1] - rec.time[0] + rec.dt)
    return noise_plan.linear.bands(BASE_BAND_MARGIN * bin_hz, EXTRA_SEQUENCES * bin_hz)


def _observable_graph(run: _Run) -> ResidualGraph:
    """Stage 2: the graph, without the extra groups the schedule cannot separate (left at their prior)."""
    graph = run.build(model_names(run.groups))
    while len(graph.names) > N_PARAMS:
        dropped = unobservable_group(graph, quick_weights(graph, run.noise_plan.model, run.rec.dt, True,
                                                          run.noise_plan.motions))
        if dropped is None:
            break
        key, partners = dropped
        run.groups = tuple(g for g in run.groups if g != key)
        message = (f"{GROUPS[key].label} ({key}) is not observable from this schedule (one with "
                   f"{', '.join(partners)}): left at {GROUPS[key].prior:g}")
        run.warnings.append(message)
        run.say(message)
        graph = run.build(model_names(run.groups))
    if run.model in ("extended", "auto"):
        graph = _separable_graph(run, graph)
    return graph


def _separable_graph(run: _Run, graph: ResidualGraph) -> ResidualGraph:
    """Stage 2b: ``extended`` and ``auto`` mean what the schedule determines: an extra group it cannot separate
    from one of the 21 (:func:`.selection.inseparable_group`) would only blur that parameter, so it is left at
    its prior, with a note naming it, its partner and what a schedule needs to separate it."""
    while len(graph.names) > N_PARAMS:
        found = inseparable_group(graph, quick_weights(graph, run.noise_plan.model, run.rec.dt, True,
                                                       run.noise_plan.motions))
        if found is None:
            break
        key, partner, correlation = found
        group = GROUPS[key]
        note = (f"{group.label} ({key}) left out of the {run.model} model: this schedule cannot separate it from "
                f"{partner} (correlation {correlation:.4f}), whose sigma it would multiply by "
                f"{1.0 / np.sqrt(max(1.0 - correlation**2, 1e-300)):.3g}; a schedule with {group.separated_by} "
                "separates it")
        run.left_out[key] = {"parameter": partner, "correlation": correlation, "note": note}
        run.groups = tuple(g for g in run.groups if g != key)
        run.say(note)
        graph = run.build(model_names(run.groups))
    return graph


def _fit_model(run: _Run, graph: ResidualGraph, use_rotation_steps) -> tuple[ResidualGraph, Fit]:
    """Stage 3: fit with the velocity steps across rotations (dropped when unmodelled), and model selection."""
    modes = [True, False] if use_rotation_steps == "auto" else [bool(use_rotation_steps)]
    if use_rotation_steps == "auto" and any(s.is_free for s in run.rec.segments):
        # a session by hand without its velocity steps across the moves leaves each rest's velocity free: the
        # accelerometers would go undetermined; a misfit there is an error outside the model (stage 4) instead
        modes = [True]
    for mode in modes:
        if not mode:  # without the steps across rotations only the groups that need no steps remain observable
            kept = tuple(g for g in groups_in(graph.names) if not GROUPS[g].needs_rotation_steps)
            if model_names(kept) != graph.names:
                left = [g for g in groups_in(graph.names) if g not in kept]
                run.warnings.append(f"without the steps across rotations {', '.join(left)} cannot be seen: left at 0")
                graph = run.build(model_names(kept))
        fit = run.fit(graph, mode)
        if run.model == "auto" and len(graph.names) > N_PARAMS:
            graph, fit = _select(run, graph, fit, mode)
        # steps that the model cannot explain: a 21-parameter fit of a unit with lever arms or a time offset
        # would take them for sensor errors; a model with those terms keeps the steps (any misfit left is an
        # unmodelled error, stage 4)
        sees_steps = any(GROUPS[g].needs_rotation_steps for g in groups_in(graph.names))
        if mode and len(modes) > 1 and not sees_steps and fit.rotation_step_ratio > STEP_CONSISTENCY_LIMIT:
            named = _evidence(run, graph, fit, "the misfit of the velocity steps across rotations")
            message = (f"the velocity steps across rotations are {np.sqrt(fit.rotation_step_ratio):.3g} times "
                       f"noisier than the static residuals: not explained by the {model_label(graph.names)} "
                       f"({'the terms named' if named else 'lever arms, timing offset?'}); refitted without them")
            run.say(message)
            run.warnings.append(message)
            continue
        break
    if describe_motion(run.noise_plan.motions):
        run.warnings.append(f"{describe_motion(run.noise_plan.motions)}: {sway_treatment(run.noise_plan.motions)}, "
                            f"the navigation steps {run.static_step_s:g} s")
    return graph, fit


def _select(run: _Run, graph: ResidualGraph, fit: Fit, mode: bool) -> tuple[ResidualGraph, Fit]:
    """``model="auto"``: keep the extra groups whose Wald statistic passes the information criterion."""
    run.selection = select_groups(graph, fit.z, fit.covariance_natural)
    chosen = tuple(g for g in run.groups if run.selection.get(g, {}).get("selected"))
    run.say("model selection: " + ", ".join(
        f"{g} {v['statistic']:.3g} (threshold {v['threshold']:.3g}) {'kept' if v['selected'] else 'left at 0'}"
        for g, v in run.selection.items()))
    if model_names(chosen) != graph.names:
        graph = run.build(model_names(chosen))
        fit = run.fit(graph, mode)
    return graph, fit


def _evidence(run: _Run, graph: ResidualGraph, fit: Fit, misfit: str) -> bool:
    """A misfit of a 21-parameter fit: do extra groups explain it (:mod:`.evidence`)?  Tried once, before
    the misfit is blamed on a bias instability or the schedule; the groups found are named once, with
    ``--model auto`` as the remedy.  Returns whether any group explains it."""
    if run.model not in ("21", None) or not is_21(graph):
        return False
    if run.evidence is None:
        saved, warnings = run.groups, list(run.warnings)
        run.groups = candidate_groups(fit.use_rotation_steps)
        extended = _observable_graph(run)
        run.groups, run.warnings = saved, warnings
        run.evidence = {} if is_21(extended) else group_evidence(run.rec, graph, fit, run.noise_plan, extended,
                                                                 run.progress)
        run.say("terms outside the 21 on this misfit: " + (", ".join(
            f"{g} {v['statistic']:.3g} (threshold {v['threshold']:.3g})" for g, v in run.evidence.items()) or "none"))
    message = evidence_warning(run.evidence, misfit)
    note = evidence_note(run.evidence, misfit)
    if note and not message and not run.notes:
        run.notes.append(note)
        run.say(f"note: {note}")
    if message and not run.evidence_named:
        run.evidence_named = True
        run.warnings.append(message)
        run.say(f"warning: {message}")
    return message is not None


def _bias_wander(run: _Run, graph: ResidualGraph, fit: Fit) -> Fit:
    """Stage 3b: the bias instability the static data show when no datasheet gives it; an included term
    enters the noise model (Gauss-Markov states in the filter) and the solve is repeated under it."""
    run.wander = estimate_bias_wander(run.rec, fit, run.noise_plan)
    if any(w.included or w.mismatch for w in run.wander.values()) and _evidence(
            run, graph, fit, "the misfit of the static data (else taken for a bias instability)"):
        for wander in run.wander.values():  # a term of the output model, not a wander
            wander.mismatch, wander.included = wander.mismatch or wander.included, False
    model = with_wander(fit.noise, run.wander)
    for sensor, wander in run.wander.items():
        run.say(f"bias instability of the {sensor} from the static data: {natural_size(sensor, wander.sigma)} "
                f"at {wander.tau:.0f} s (likelihood ratio "
                f"{wander.lr:.3g}, {'included' if wander.included else 'not included'}"
                f"{', taken for model mismatch' if wander.mismatch else ''})")
    if model is None:
        return fit
    stats, before = fit.ipopt_stats, fit.covariance_natural
    fit = generalised_least_squares(run.rec, graph, run.noise_plan, model, fit.z, fit.use_rotation_steps,
                                    run.progress, update_free=False, relinearise=run.relinearise)
    fit.ipopt_stats = stats
    for sensor, wander in run.wander.items():
        if wander.included:  # what it cost (natural units scale each bias alike: the ratio is unit-free)
            wander.cost = bias_cost(before, fit.covariance_natural, graph.names, sensor)
    record(run.noise_plan, run.wander)
    message = describe(run.wander)
    if message:
        run.warnings.append(message)  # shown once with the result's warnings (the CLI's WARNING lines)
    return fit


def _assess(run: _Run, graph: ResidualGraph, fit: Fit) -> tuple[Fit, Assessment]:
    """Stage 4: the checks; errors outside the model get a place in it and the solve is repeated."""
    assessment = assess(graph, fit, run.noise_plan)
    if not assessment.model_fails:
        return fit, assessment
    _evidence(run, graph, fit, "the misfit beyond the noise model")
    # errors outside the model: an unmodelled acceleration per static segment, an unmodelled rate per gyro
    # mean (and a velocity error per rotation), with variances from the residuals, and solve again
    unmodelled, tops = estimate_unmodelled(graph.observations, fit.residuals, fit.jacobian, fit.system, fit.noise,
                                     fit.use_rotation_steps)
    run.say(f"residuals exceed the noise model: unmodelled acceleration {unmodelled.unmodelled_acceleration / UG:.3g} "
            f"ug per static segment, unmodelled rate {unmodelled.unmodelled_rate / DEG_PER_H:.3g} deg/h per gyro mean, "
            f"unmodelled step {unmodelled.unmodelled_step * 1e3:.3g} mm/s per rotation added")
    stats = fit.ipopt_stats
    fit = generalised_least_squares(run.rec, graph, run.noise_plan, unmodelled, fit.z, fit.use_rotation_steps,
                                    run.progress, update_free=False, relinearise=run.relinearise)
    fit.ipopt_stats = stats
    first = [c for c in assessment.checks if not c.passed and c.value > c.limit]  # beyond (not below) the model
    assessment = assess(graph, fit, run.noise_plan)
    final = {c.name: c for c in assessment.checks}
    failed = [f"{c.name} {c.value:.3g} against the limit {c.limit:.3g}" + (
        f", now {final[c.name].value:.3g} ({'passed' if final[c.name].passed else 'still failed'})"
        if c.name in final else "") for c in first]
    step = (f", {unmodelled.unmodelled_step * 1e3:.3g} mm/s per velocity step across a rotation"
            if fit.use_rotation_steps else "")
    run.warnings += unmodelled_at_bounds(unmodelled, tops)
    run.distrust += unmodelled_at_bounds(unmodelled, tops, binding_only=True)  # a MEMS unit's unbounded term: no doubt
    run.warnings.append(f"under the sensor noise alone the residuals exceeded it ({'; '.join(failed)}; the Checks "
                        "table is of the final fit): errors outside the model "
                        f"were added to it: {unmodelled.unmodelled_acceleration / UG:.3g} ug unmodelled acceleration "
                        f"per static segment, {unmodelled.unmodelled_rate / DEG_PER_H:.3g} deg/h per static gyro "
                        f"mean{step}; sigma includes them")
    return fit, assessment


def _result(run: _Run, graph: ResidualGraph, fit: Fit, assessment: Assessment, timings: dict) -> CalibrationResult:
    """Stage 5: the parameter table with its covariance, and everything the report needs."""
    rec, names, reference = run.rec, graph.names, graph.reference
    n_params = len(names)
    covariance_w = fit.covariance_natural * assessment.variance_factor
    values = natural_to_parameters(fit.z[:n_params], reference, names)
    scale = variable_scale(reference, names)
    covariance = covariance_w[:n_params, :n_params] * np.outer(scale, scale)
    offsets = graph.start_offsets(fit.z)
    start_attitudes = {g: rotation_matrices(offsets[g] * ARCSEC) @ graph.start_attitudes[g] for g in rec.group_ids}
    model = fit.noise
    white = {"accel_noise_ug": float(np.mean(model.accel_vrw)) / np.sqrt(rec.dt) / UG,
             "gyro_noise_deg_h": float(np.mean(model.gyro_arw)) / np.sqrt(rec.dt) / DEG_PER_H,
             "velocity_white_mps": float(np.sqrt(np.mean(model.accel_quantization**2)))}
    nat = model.natural()
    run.say(f"noise model: ARW {_fmt(nat['gyro_arw_deg_rth'])} deg/sqrt(h) ({run.noise_plan.source['gyro_arw']}), "
            f"VRW {_fmt(nat['accel_vrw_ug_rthz'])} ug/sqrt(Hz) ({run.noise_plan.source['accel_vrw']}); variance "
            f"factors velocity {assessment.factors['velocity']:.3g}, gyro {assessment.factors['gyro']:.3g}")
    params = ParameterSet(values, covariance=covariance, names=names)
    remedy = ("their sigma carries the misfit of the terms outside the model named above (--model auto), not "
              "the schedule") if run.evidence_named else SCHEDULE_REMEDY
    # a navigation-grade unit is judged by the navigation-grade levels; any other by what its own noise could give
    levels = None if run.navigation_grade else grade_levels(names, model, rec)
    separation_checks, separation_text = separation_warnings(params, run.wander, remedy, levels)
    assessment.checks += separation_checks
    assessment.warnings += separation_text
    warnings = run.warnings + run.noise_plan.warnings + assessment.warnings  # shown once, with the result
    stats = fit.ipopt_stats
    details = NlpDetails(stats["return_status"], int(stats["iter_count"]), fit.gls_steps, fit.use_rotation_steps,
                         fit.rotation_step_ratio, offsets, start_attitudes, groups_in(names), run.selection,
                         run.observe_s, run.static_step_s, timings["graph"], graph.observations,
                         fit.whitened_residuals, white, run.left_out)
    status, message = outcome(warnings, int(stats["iter_count"]))
    return CalibrationResult(
        params, "nlp", True, status, message,
        int(stats["iter_count"]), run.initial, [reference, values],
        float(np.sqrt(np.mean(fit.whitened_residuals**2))), time.perf_counter() - run.t_start, SIGMA_MEANING,
        warnings, assessment.checks, assessment.variance_factor,
        NoiseReport(model, run.noise_plan.raw, assessment.fitted_noise, dict(run.noise_plan.source), run.wander),
        run.noise_plan.motions, timings, nlp=details, notes=run.notes, linear_motion=run.noise_plan.linear,
        distrust=run.distrust)


def _fmt(values) -> str:
    return "/".join(f"{v:.3g}" for v in np.atleast_1d(values))
