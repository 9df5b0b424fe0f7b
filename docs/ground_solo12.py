"""Draws docs/ground_solo12.png, the README's "A ground to stand on": Solo-12 dropped on its
four feet from 0.3 m, its joints held (``mbgen simulate solo12 --floating --ground
FL_FOOT,FR_FOOT,HL_FOOT,HR_FOOT --hold 50,0.5`` in Python).

Run from the repository root: ``.venv/bin/python docs/ground_solo12.py`` (about a minute:
the model is derived and compiled first; needs the ``plot`` and ``test`` extras)."""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import mbgen  # noqa: E402
from mbgen import Output  # noqa: E402
from mbgen.model.hold import reference_name  # noqa: E402

FEET = "FL_FOOT,FR_FOOT,HL_FOOT,HR_FOOT"


OUT = Path(__file__).with_suffix(".png")


def main(out: Path = OUT) -> Path:
    scene = mbgen.load_scene("solo12", floating="true", ground=FEET, hold="50,0.5")
    c = mbgen.compile(scene, scene.outputs + (Output.ENERGY, Output.POSITIONS))
    traj = mbgen.simulate(c, scene.x0(c.layout), scene.t_span, n_out=601, stiff=True)
    p, names = c.parameter_defaults, c.state_names
    joints = [n for n in names[:c.layout.n_q] if reference_name(n) in p]
    feet = np.array([c.positions(0.0, x)[:, 2] for x in traj.x])
    energy = []
    for x, h in zip(traj.x, np.minimum(feet, 0.0)):
        bent = np.array([x[names.index(q)] - p[reference_name(q)] for q in joints])
        energy.append(c.energy(0.0, x).sum() + 0.5 * p["k_ground"] * h @ h
                      + 0.5 * p["kp_hold"] * bent @ bent)
    early = traj.t <= 1.0
    fig, (a, b, s) = plt.subplots(1, 3, figsize=(9, 2.5), dpi=80, layout="constrained")
    a.plot(traj.t[early], traj.x[early, names.index("root_z")], label="base")
    a.plot(traj.t[early], feet[early].mean(axis=1), label="feet (mean)")
    a.axhline(0.0, color="0.5", lw=0.8)
    a.set(xlabel="t (s)", ylabel="height (m)", title="dropped from 0.3 m")
    a.legend(frameon=False)
    b.plot(traj.t[early], np.array(energy)[early], color="C3")
    b.set(xlabel="t (s)", ylabel="E (J)", title="T + V + ground, hold springs")
    s.semilogy(traj.t, np.abs(traj.x[:, c.layout.n_q:]).max(axis=1), color="C2")
    s.set(xlabel="t (s)", ylabel="max |u|", title="coming to rest")
    fig.savefig(out)
    print(f"{out}: {traj.method}, {traj.nfev} RHS calls, {traj.wall_time:.3f} s")
    return out


if __name__ == "__main__":
    main()
