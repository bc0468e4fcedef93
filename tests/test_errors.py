"""Errors are chosen by fault, whatever the entry point, exported from dhkin, and carry their parts
as attributes (field, value, expected, index) so that no caller parses a message."""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

import dhkin
from dhkin import errors
from dhkin.errors import (
    DhkinError,
    FamilyError,
    InputError,
    UnreachableError,
    describe,
)


def test_every_error_class_is_exported_from_dhkin() -> None:
    classes = {name for name, value in vars(errors).items()
               if inspect.isclass(value) and issubclass(value, DhkinError)}
    assert classes <= set(dhkin.__all__)
    for name in classes:
        assert getattr(dhkin, name) is getattr(errors, name)


def test_earlier_names_are_the_input_error() -> None:
    assert dhkin.IKInputError is InputError
    assert dhkin.SingularityError is InputError
    assert dhkin.ValidationInputError is InputError


def test_message_is_composed_from_the_attributes() -> None:
    error = InputError(field="q_seed", value=(5,), expected="shape (6,)", index=3)
    assert str(error) == "q_seed[3]: expected shape (6,), got (5,)"
    assert (error.field, error.value, error.expected, error.index) == ("q_seed", (5,),
                                                                        "shape (6,)", 3)
    assert describe("tolerance", None, "a positive number") == \
        "tolerance: expected a positive number"
    plain = FamilyError("free text")
    assert str(plain) == "free text" and plain.field is None and plain.index is None


@pytest.mark.parametrize("call", [
    lambda robot, q: robot.fk(q),
    lambda robot, q: robot.singularity(q),
    lambda robot, q: robot.reference().fk(q),
    lambda robot, q: robot.ik(robot.fk(np.zeros(6)), q_seed=q),
    lambda robot, q: robot.ik_batch(robot.fk(np.zeros((2, 6))), q_seed=q),
], ids=["fk", "singularity", "reference.fk", "ik seed", "ik_batch seed"])
def test_a_wrong_shape_joint_vector_is_an_input_error_everywhere(call, load_robot) -> None:
    robot = load_robot("ur5")
    with pytest.raises(InputError) as caught:
        call(robot, np.zeros(5))
    assert caught.value.field in ("q", "q_seed")


def test_a_rejected_pose_of_a_batch_names_its_index(load_robot) -> None:
    robot = load_robot("abb_irb1200_7_70")
    poses = robot.fk(np.zeros((4, 6)))
    poses[2, 3, 0] = 0.5  # bottom row not [0, 0, 0, 1]
    with pytest.raises(InputError, match=r"T\[2\]") as caught:
        robot.ik_batch(poses)
    assert (caught.value.field, caught.value.index) == ("T", 2)


def test_bad_tolerance_names_the_field(load_robot) -> None:
    robot = load_robot("ur5")
    with pytest.raises(InputError) as caught:
        robot.ik(robot.fk(np.zeros(6)), tolerance=-1.0)
    assert caught.value.field == "tolerance"


def test_a_table_outside_the_families_is_a_family_error(load_robot) -> None:
    with pytest.raises(FamilyError):
        load_robot("planar_2r").singularity(np.zeros(2))


def test_a_singularity_out_of_reach_is_unreachable(load_robot) -> None:
    from dhkin.singularity import singularity_model

    table = load_robot("ur5").table
    # joint 5 limited to [0.5, 1] rad: the wrist singularity (q5 = 0 or pi) is out of its reach
    joints = tuple(dataclasses.replace(joint, lower=0.5, upper=1.0) if k == 4 else joint
                   for k, joint in enumerate(table.joints))
    narrowed = dataclasses.replace(table, joints=joints)
    with pytest.raises(UnreachableError, match="outside its limits") as caught:
        singularity_model(narrowed).place(np.full(6, 0.7), "wrist")
    assert caught.value.field == "q"
