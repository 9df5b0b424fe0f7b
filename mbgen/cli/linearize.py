"""``mbgen linearize SCENE``: A, B and eigenvalues at the scene's initial state (made
consistent with its constraints), optionally written as ``A.csv`` and ``B.csv``."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..abi import Output
from ..errors import EXIT_OK
from ..fileio import write_atomic
from ..pipeline import compile
from ..runtime.linearize import linearize
from ._common import (
    add_number_arguments,
    add_scene_arguments,
    check_folder,
    constant_inputs,
    initial_state,
    scene_from,
    with_numbers,
)


def configure(p: argparse.ArgumentParser) -> None:
    add_scene_arguments(p, method_flag=True)
    p.add_argument("-x", "--state", action="append", metavar="NAME=VALUE",
                   help="operating point: a state's value (repeatable; default the scene's "
                        "initial state, made consistent with its constraints)")
    add_number_arguments(p, states=False)
    p.add_argument("-o", "--output", metavar="DIR", help="write A.csv and B.csv into DIR")


def run(args) -> int:
    if args.output:
        check_folder(args.output, "-o")
    scene = with_numbers(scene_from(args), args)
    outputs = [Output.RHS, Output.JACOBIAN]
    model_eq = scene.model
    constrained = bool(getattr(model_eq, "constraints_", None) or
                       getattr(model_eq, "constraints", None))
    if constrained:
        outputs += [Output.HOLONOMIC, Output.HOLONOMIC_JACOBIAN]
    model = compile(scene, outputs + ([Output.INPUT_JACOBIAN] if _has_inputs(scene) else []))
    x = initial_state(scene, model)
    r = constant_inputs(args, model)
    if model.dependent_coordinates:
        x = model.consistent(x, r=r)
    lin = linearize(model, x, scene.p(model.layout), r)
    print(f"{scene.name}: operating point " + ", ".join(
        f"{n} = {v:.6g}" for n, v in zip(model.state_names, x)))
    print(lin.format())
    if args.output:
        folder = Path(args.output)
        for name, matrix, cols in (("A", lin.A, lin.states), ("B", lin.B, lin.inputs)):
            text = ",".join(cols) + "\n" + "".join(
                ",".join(repr(float(v)) for v in row) + "\n" for row in np.atleast_2d(matrix))
            write_atomic(folder / f"{name}.csv", text)
        print(f"wrote {folder / 'A.csv'} and {folder / 'B.csv'} (rows and columns: "
              f"{', '.join(lin.states)})")
    return EXIT_OK


def _has_inputs(scene) -> bool:
    model = scene.model
    inputs = getattr(model, "inputs_", None)
    if inputs is None:
        inputs = model.layout.inputs
    return bool(inputs) and scene.inputs != ()
