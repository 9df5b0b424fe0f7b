"""The slicing audit (``mbgen generate --explain``) says which derivation the code uses and why,
and audits the code of that derivation (the scene's, or the default's choice)."""

from dataclasses import replace

from mbgen.cli import main
from mbgen.model.scene import load_scene
from mbgen.pipeline import run
from mbgen.verify.audit import audit


def test_audit_names_the_derivation_and_why():
    chosen = replace(load_scene("car_trailer"), method=None)
    report = audit(chosen)
    generated = run(chosen, build=False)
    assert report.derivation == generated.equations.derivation
    assert report.derivation.startswith("Newton-Euler (chosen: ")
    assert report.sliced_ops == generated.kernel.ops_after        # the code of that derivation
    assert report.format().splitlines()[1] == f"derivation: {report.derivation}"
    assert (audit(load_scene("car_trailer")).derivation
            == "Newton-Euler (named by the scene or --derivation)")


def test_generate_explain_prints_it(tmp_path, capsys):
    assert main(["generate", "disc_pendulum", "--explain", "-o", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "\nderivation: Kane's method (chosen: " in out and "against Newton-Euler's" in out
