"""``hertzian check``: before running, the stiffest contact time scale of a scene and whether dt is safe."""

from __future__ import annotations

import json
from typing import Annotated

import typer
from hertzian.cli.app import PrecisionOption, SceneArgument, SetOption, app, fail, load_scene_or_fail


@app.command()
def check(
    scene: SceneArgument = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the estimates as a JSON object.")] = False,
    precision: PrecisionOption = None,
    set_: SetOption = None,
):
    """Before running: the stiffest contact time scale of a scene, steps per contact time, and whether dt is safe.

    Bounds the largest overlap (static overlaps plus the impact energy or drive), takes the
    linearised stiffness n(n−1)a_c δ^(n−2) there and the contact time T = 2π sqrt(m_red/k),
    and compares dt with each method's stability limit (ω_max·dt) and with the steps per
    contact time measured to keep the energy error below 1e-6 (docs/stability.md). Program units.
    """
    from hertzian.core.check import ACCURATE_STEPS_PER_CONTACT_TIME, STABLE_OMEGA_DT, check_scene, memory_refusal
    from hertzian.core.scene import VALIDITY_FRACTION

    loaded = load_scene_or_fail(scene, set_, precision)
    too_big = memory_refusal(loaded)
    if too_big:
        fail(too_big)
    result = check_scene(loaded)
    tolerance = loaded.integrator.tolerance
    if tolerance is not None:  # the pilot runs pick method (with "auto") and dt: no dt to judge yet
        _print_tolerance_check(loaded, result, as_json)
        return
    if as_json:
        typer.echo(json.dumps(result.to_dict(), indent=1))
        return
    n = loaded.chain.grains

    def where(k: int) -> str:
        return ("surface wall" if k == 0 else "bottom wall" if k == n else f"grains {k - 1}–{k}") if k >= 0 else "none"

    limit = f"validity limit {VALIDITY_FRACTION:g}·diameter"
    if loaded.chain.radius_ratios is not None:  # per contact, set by its smaller grain: name the nearest to it
        limit = f"{where(result.validity_contact)}, nearest its validity limit {VALIDITY_FRACTION:g}·(smaller diameter)"
    lines = [
        f"largest overlap (bound)   {result.largest_overlap:.4g}  ({limit} = {result.validity_overlap:g})",
        f"stiffest contact          {where(result.stiffest_contact)}: k = {result.stiffness:.4g}, "
        f"m_red = {result.reduced_mass:.4g}",
        f"contact time T            {result.contact_time:.4g}  (2π sqrt(m_red/k))",
        f"dt                        {result.dt:g} ({result.method}, {loaded.integrator.precision})",
        f"steps per contact time    {result.steps_per_contact_time:.4g}  (accurate ≥ "
        f"{ACCURATE_STEPS_PER_CONTACT_TIME[result.method]:g}"
        + (
            f"; the scene accepts ≥ {result.accepted_steps:g}: integrator.accepted_steps_per_contact)"
            if result.accepted_steps is not None
            else ")"
        ),
        f"ω_max·dt                  {result.omega_dt:.4g}  (stable ≤ {STABLE_OMEGA_DT[result.method]:.3g})",
        f"suggested dt              {result.suggested_dt:.3g}",
        f"verdict                   {result.verdict}",
    ]
    for line in lines:
        typer.echo(line)
    for note in result.notes:
        typer.echo(f"note: {note}")
    warning = result.warning()
    if warning:
        typer.echo(f"warning: {warning}")


TOLERANCE_KEYS = ("largest_overlap", "validity_overlap", "beyond_validity", "stiffest_contact", "stiffness")
"""What ``check`` reports of a tolerance scene: the contact's scales, which need no dt."""


def _print_tolerance_check(scene, result, as_json: bool) -> None:
    """``check`` of a scene with ``integrator.tolerance``: the stiffest contact and its time scale; the method
    (with "auto") and dt are chosen by the pilot runs, so there is no dt to judge."""
    integrator = scene.integrator
    chooser = f"integrator.tolerance = {integrator.tolerance:g}: pilot runs pick " + (
        "the method and dt" if integrator.method == "auto" else f"dt for {integrator.method}"
    )
    if as_json:
        numbers = {k: getattr(result, k) for k in TOLERANCE_KEYS}
        numbers |= {"reduced_mass": result.reduced_mass, "contact_time": result.contact_time}
        typer.echo(json.dumps({**numbers, "tolerance": integrator.tolerance, "method": integrator.method}, indent=1))
        return
    typer.echo(f"largest overlap (bound)   {result.largest_overlap:.4g}  (validity limit {result.validity_overlap:g})")
    typer.echo(f"stiffest contact          k = {result.stiffness:.4g}, m_red = {result.reduced_mass:.4g}")
    typer.echo(f"contact time T            {result.contact_time:.4g}  (2π sqrt(m_red/k))")
    typer.echo(f"dt                        {chooser}")
    for note in result.notes:
        typer.echo(f"note: {note}")
