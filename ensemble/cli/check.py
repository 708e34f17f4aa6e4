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
        f"{ACCURATE_STEPS_PER_CONTACT_TIME[result.method]:g})",
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
