"""Config validation: every problem reported at once, one line each naming the key."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
from conftest import CONFIGS, run_cli, run_subprocess

from shapegrowth.config import ConfigError, from_dict, load

BASE = """\
name: t
geometry: {kind: box, length: 1.0, width: 0.1, thickness: 0.02}
mesh: {size: 0.05, layers: 1}
boundary: {clamp: x1_min}
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "c.yaml"
    path.write_text(textwrap.dedent(text))
    return path


def problems(tmp_path: Path, text: str, overrides=()) -> list[str]:
    with pytest.raises(ConfigError) as err:
        load(write(tmp_path, text), list(overrides))
    return err.value.problems


def test_minimal_config_gets_documented_defaults(tmp_path):
    cfg = load(write(tmp_path, BASE))
    assert cfg.model.degree == 2 and cfg.quadrature_degree == 4
    assert cfg.growth.eigenvalues.initial == (1.0, 1.0, 1.0)
    assert cfg.growth.eigenvalues.bounds == (0.01, 12.0)
    assert cfg.growth.eigenvalues.design == (1, 2, 3)
    assert cfg.loads.body_force == (0.0, 0.0, 0.0)
    assert cfg.output_dir == Path("results/t")
    assert cfg.objective.hausdorff.form == "debiased"
    assert cfg.objective.hausdorff.alphas == (100.0,)


def test_an_alpha_schedule_is_a_list(tmp_path):
    cfg = load(write(tmp_path, BASE), ["objective.hausdorff.alpha=[100, 300, 1000]"])
    assert cfg.objective.hausdorff.alphas == (100.0, 300.0, 1000.0)


@pytest.mark.parametrize("extra, key, words", [
    ("geometry: {kind: box, lenght: 1.0, width: 0.1, thickness: 0.02}", "geometry.lenght",
     "did you mean 'length'"),
    ("geometry: {kind: box, length: -1.0, width: 0.1, thickness: 0.02}", "geometry.length",
     "must be > 0"),
    ("growth: {eigenvalues: {bounds: [12.0, 0.01]}}", "growth.eigenvalues.bounds", "lower < upper"),
    ("growth: {frame: spherical}", "growth.frame", "allowed: cartesian"),
    ("mesh: {size: fine}", "mesh.size", "expected a number"),
    ("growth: {eigenvalues: {initial: [20.0, 1, 1]}}", "growth.eigenvalues.initial[0]",
     "outside the bounds"),
    ("growth: {eigenvalues: {initial: [\"__import__('os').system('touch /tmp/x')\", 1, 1]}}",
     "growth.eigenvalues.initial[0]", "may be called"),
    ("boundary: {clamp: inner_rim}", "boundary.clamp", "allowed: x1_min"),
    ("boundary: {clamp: [x1_min, inner_rim]}", "boundary.clamp", "'inner_rim' is not a"),
    ("boundary: {clamp: [x1_min, rigid]}", "boundary.clamp", "stands alone"),
    ("boundary: {clamp: [x1_max, x1_max]}", "boundary.clamp", "names a boundary twice"),
    ("boundary: {clamp: []}", "boundary.clamp", "an empty list"),
    ("boundary: {clamp: [x1_min, x1_max]}\nmesh: {size: 0.05, clamp_size: 0.01}",
     "mesh.clamp_size", "grades the mesh towards a clamp"),
    ("solver: {linear: superlu}", "solver.linear", "allowed: mumps, mumps_ldlt"),
    ("model: {dim: 2, reduction: axisymmetric}", "model.reduction", "a box reduces to"),
    ("mesh: {size: 0.05, clamp_size: 0.1}", "mesh.clamp_size", "smaller than mesh.size"),
    ("boundary: {clamp: rigid}\nmesh: {size: 0.05, clamp_size: 0.01}", "mesh.clamp_size",
     "box clamped at x1_min, tube clamped at x1_min"),
    ("loads: {traction: {x9_max: [0, 0, 1]}}", "loads.traction.x9_max", "not a boundary"),
    ("objective: {hausdorff: {alpha: [1000, 300]}}", "objective.hausdorff.alpha",
     "must not decrease"),
    ("objective: {hausdorff: {alpha: [100, -3]}}", "objective.hausdorff.alpha",
     "positive number"),
    ("objective: {hausdorff: {cutoff: 6, taper: 8}}", "objective.hausdorff.taper",
     "wider than the cutoff"),
    ("objective: {hausdorff: {form: unbiased}}", "objective.hausdorff.form",
     "allowed: debiased, paper"),
    ("objective: {hausdorff: {phi: rational, precision: float32}}",
     "objective.hausdorff.precision", "needs phi: exp"),
    ("optimizer: {algorithm: bfgs}", "optimizer.algorithm", "allowed: mma, slsqp, lbfgs"),
    ("target: {map: [x1, x2, x3], weights: area}", "target.weights",
     "allowed: volume, pushforward"),
])
def test_each_bad_input_names_its_key(tmp_path, extra, key, words):
    text = BASE
    section = extra.split(":")[0]
    if section + ":" in text:
        text = "\n".join(line for line in text.splitlines() if not line.startswith(section + ":"))
    lines = problems(tmp_path, text + "\n" + extra + "\n")
    assert any(line.startswith(key + ":") and words in line for line in lines), lines


def test_all_problems_at_once(tmp_path):
    lines = problems(tmp_path, """\
        name: t
        geometry: {kind: box, length: -1, width: 0.1}
        mesh: {size: 0}
        boundary: {clamp: nowhere}
        growth: {frame: spherical}
        """)
    keys = {line.split(":")[0] for line in lines}
    assert {"geometry.length", "geometry.thickness", "mesh.size", "boundary.clamp",
            "growth.frame"} <= keys


def test_set_overrides_and_unknown_set_key(tmp_path):
    path = write(tmp_path, BASE)
    cfg = load(path, ["mesh.size=0.1", "growth.eigenvalues.initial=[2, 1, 1]",
                      "parameters.kappa=3"])
    assert cfg.mesh.size == 0.1 and cfg.growth.eigenvalues.initial == (2.0, 1.0, 1.0)
    assert cfg.parameters == {"kappa": 3.0}
    with pytest.raises(ConfigError) as err:
        load(path, ["mesh.sise=0.1"])
    assert err.value.problems == ["--set mesh.sise: unknown key (did you mean 'mesh.size'?)"]


def test_broken_yaml_and_missing_file(tmp_path):
    lines = problems(tmp_path, "name: [unclosed\n")
    assert len(lines) == 1 and lines[0].startswith("config: broken YAML") and "line" in lines[0]
    with pytest.raises(ConfigError) as err:
        load(tmp_path / "nope.yaml")
    assert err.value.problems == [f"config: file '{tmp_path / 'nope.yaml'}' not found"]


def test_incompressible_takes_one_value_less():
    raw = {"name": "t", "geometry": {"kind": "cube", "side": 1.0}, "mesh": {"size": 0.5},
           "boundary": {"clamp": "rigid"},
           "growth": {"eigenvalues": {"incompressible": True, "initial": [2.0, 0.5]}}}
    assert from_dict(raw).growth.eigenvalues.design == (1, 2)
    raw["growth"]["eigenvalues"]["initial"] = [2.0, 0.5, 1.0]
    with pytest.raises(ConfigError, match="give 2 values"):
        from_dict(raw)


# wrong values of every kind: a word, a negative number, a list, a mapping, nothing
_WRONG = ("not_a_choice", "-1", "[1, 2]", "{a: 1}", "null")


def _leaf_keys() -> list[str]:
    import dataclasses

    from shapegrowth.config import Config
    from shapegrowth.config.schema import field_paths

    return [key for key, tp in field_paths(Config).items()
            if not any(dataclasses.is_dataclass(a) for a in (tp, *getattr(tp, "__args__", ())))]


def test_every_wrong_value_of_every_key_is_a_config_error_naming_a_key(tmp_path):
    """Each key of the schema set to each wrong value (on a box, a tube and a cube): the
    config loads or raises ConfigError whose lines each name a key; no other exception (a
    wrong geometry.kind once ended in a KeyError of the cross-field rules)."""
    import yaml

    keys = _leaf_keys()
    assert "geometry.kind" in keys and "growth.frame" in keys and len(keys) > 80
    bases = [yaml.safe_load(BASE),
             {"name": "t", "geometry": {"kind": "tube", "length": 3.0, "radius": 1.0,
                                        "thickness": 0.1}, "mesh": {"size": 0.5},
              "boundary": {"clamp": "x1_min"}},
             {"name": "t", "geometry": {"kind": "cube", "side": 1.0}, "mesh": {"size": 0.5},
              "boundary": {"clamp": "rigid"}}]
    refused = 0
    for raw in bases:
        for key in keys:
            for value in _WRONG:
                try:
                    from_dict(raw, [f"{key}={value}"])
                except ConfigError as err:
                    refused += 1
                    assert err.problems, key
                    for line in err.problems:
                        head = line.split(":", 1)[0]
                        assert line.count("\n") == 0 and " " not in head.strip("-"), (key, line)
    assert refused > 2 * len(keys)


def test_a_kind_that_is_not_listed_is_one_line_naming_the_key():
    raw = {"name": "t", "geometry": {"kind": "blob", "length": 1.0}, "mesh": {"size": 0.5},
           "boundary": {"clamp": "x1_min"}}
    with pytest.raises(ConfigError) as err:
        from_dict(raw)
    assert err.value.problems == ["geometry.kind: 'blob' is not allowed (allowed: box, tube, "
                                  "annulus, cylinder_shell, rectangle, cube, file)"]


@pytest.mark.parametrize("kind, cells, dim, degree", [
    ("tube", "hex", 3, 2), ("annulus", "hex", 3, 2), ("cylinder_shell", "hex", 3, 2),
    ("box", "hex", 3, 1), ("tube", "simplex", 3, 1), ("annulus", "hex", 2, 1)])
def test_the_growth_degree_defaults_to_two_on_curved_hexahedra(kind, cells, dim, degree):
    geometry = {"tube": {"length": 3.0, "radius": 1.0, "thickness": 0.1},
                "annulus": {"radius": 1.0, "inner_radius": 0.3, "thickness": 0.05},
                "cylinder_shell": {"radius": 1.0, "height": 0.7, "thickness": 0.05},
                "box": {"length": 1.0, "width": 0.1, "thickness": 0.02}}[kind]
    raw = {"name": "t", "geometry": {"kind": kind, **geometry},
           "mesh": {"size": 0.5, "cells": cells},
           "model": {"dim": dim} | ({"reduction": "axisymmetric"} if dim == 2 else {}),
           "boundary": {"clamp": "inner_rim" if kind == "annulus" else
                        "bottom_rim" if kind == "cylinder_shell" else "x1_min"}}
    raw["growth"] = {"frame": "cylindrical" if kind == "annulus" else "cartesian"}
    assert from_dict(raw).growth.degree == degree
    raw["growth"]["degree"] = 3 - degree  # a degree given is kept
    assert from_dict(raw).growth.degree == 3 - degree


def test_cli_validate_exit_codes(tmp_path, capsys):
    assert run_cli("validate", CONFIGS / "beam_bend.yaml") == 0
    bad = write(tmp_path, BASE.replace("size: 0.05", "size: -1"))
    assert run_cli("validate", bad) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["error: mesh.size: -1.0 must be > 0"]


def test_cli_bad_input_prints_no_traceback(tmp_path):
    marker = tmp_path / "hacked"
    bad = write(tmp_path, BASE + f"growth: {{eigenvalues: {{initial: "
                                 f"[\"__import__('os').system('touch {marker}')\", 1, 1]}}}}\n")
    result = run_subprocess(["solve", bad])
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert result.stderr.strip().startswith("error: growth.eigenvalues.initial[0]:")
    assert len(result.stderr.strip().splitlines()) == 1
    assert not marker.exists()


def test_the_config_reference_is_generated_from_the_schema():
    """docs/CONFIG.md cannot drift: regenerate it with scripts/config_reference.py."""
    from conftest import ROOT

    from shapegrowth.config import reference_text

    assert (ROOT / "docs" / "CONFIG.md").read_text() == reference_text()


def test_start_from_the_target_says_what_it_needs():
    """start: target needs a map and replaces the initial values: every conflict in one
    error, one line each."""
    raw = {"name": "t", "geometry": {"kind": "cube", "side": 1.0}, "mesh": {"size": 0.5},
           "model": {"dim": 3}, "boundary": {"clamp": "rigid"},
           "growth": {"frame": "free", "start": "target", "eigenvalues": {"initial": [2, 2, 2]}},
           "target": {"mesh": "disk.msh"}}
    with pytest.raises(ConfigError) as err:
        from_dict(raw)
    lines = [p for p in err.value.problems if p.startswith(("growth.start", "growth.eigen"))]
    assert len(lines) == 2
    assert any("needs target.map" in p for p in lines)
    assert any(p.startswith("growth.eigenvalues.initial: start: target") for p in lines)


def test_a_clamp_is_one_boundary_or_a_list_of_them(tmp_path):
    """``boundary.clamp`` takes a name or a list; ``clamped`` gives both as a tuple."""
    from shapegrowth.config import load

    one = load(CONFIGS / "tiny" / "beam_bend.yaml")
    both = load(CONFIGS / "tiny" / "beam_bend.yaml", ["boundary.clamp=[x1_min, x1_max]"])
    assert one.boundary.clamped == ("x1_min",)
    assert both.boundary.clamped == ("x1_min", "x1_max")
    assert list(both.to_dict()["boundary"]["clamp"]) == ["x1_min", "x1_max"]


def test_compare_names_faces_of_the_body_and_refuses_what_it_cannot_compare():
    """objective.compare: volume (default), boundary, a face or a list of them, resolved to
    the body's boundaries (box: top is x3_max); each wrong use refused in one line."""
    beam = CONFIGS / "tiny" / "beam_wave.yaml"
    assert load(beam).objective.faces("box") is None
    assert load(beam, ["objective.compare=boundary"]).objective.faces("box") == ()
    assert load(beam, ["objective.compare=[top, x1_max]"]).objective.faces("box") \
        == ("x3_max", "x1_max")
    refused = {
        "objective.compare=lid": "objective.compare: lid is not volume, boundary or faces of "
                                 "a box (faces: top, bottom, x1_min, x1_max, x2_min, x2_max, "
                                 "x3_min, x3_max)",
        "objective.compare=[top, top]": "objective.compare: ['top', 'top'] names a face "
                                        "twice; name each once",
        "objective.compare=[volume, top]": "objective.compare: ['volume', 'top'] is not "
                                           "volume, boundary or faces of a box (faces: top, "
                                           "bottom, x1_min, x1_max, x2_min, x2_max, x3_min, "
                                           "x3_max)",
    }
    for setting, message in refused.items():
        with pytest.raises(ConfigError) as err:
            load(beam, [setting])
        assert err.value.problems == [message]
    assert load(beam, ["objective.compare=top", "model.dim=2", "mesh.layers=2"]) \
        .objective.faces("box") == ("x3_max",)  # the section's top edge stands for the face
    with pytest.raises(ConfigError) as err:
        load(beam, ["objective.compare=x2_min", "model.dim=2", "mesh.layers=2"])
    assert err.value.problems == ["objective.compare: 'x2_min' is not on the section a 2D "
                                  "model of a box keeps; compare a face in the plane, or use "
                                  "model.dim: 3"]


def test_a_fitted_placement_is_for_a_free_body():
    """objective.placement: fitted moves a free body onto its best fit; with a clamp it is
    refused in one line."""
    beam = CONFIGS / "tiny" / "beam_wave.yaml"
    assert load(beam).objective.placement == "pinned"
    assert load(beam, ["boundary.clamp=rigid", "objective.placement=fitted"]) \
        .objective.placement == "fitted"
    with pytest.raises(ConfigError) as err:
        load(beam, ["objective.placement=fitted"])
    assert err.value.problems == [
        "objective.placement: fitted moves a free body (boundary.clamp: rigid) onto its best "
        "fit; a clamped body stands where its clamp holds it: use placement: pinned or "
        "clamp: rigid"]


def test_verify_best_verified_needs_the_checks_it_chooses_among(tmp_path):
    """verify.best: verified without verify.every (or with the verification off) is one
    line naming the key and the fix; with every, the config loads."""
    for sets in (["verify.best=verified"],
                 ["verify.best=verified", "verify.every=5", "verify.enabled=false"]):
        lines = problems(tmp_path, BASE, sets)
        assert lines == ["verify.best: 'verified' chooses among verify.every's checks; set "
                         "verify.every (e.g. 20) with verify.enabled: true, or verify.best: "
                         "self"], lines
    cfg = load(write(tmp_path, BASE), ["verify.best=verified", "verify.every=5"])
    assert cfg.verify.best == "verified" and cfg.verify.every == 5
    assert "allowed" in problems(tmp_path, BASE, ["verify.best=lowest"])[0]
