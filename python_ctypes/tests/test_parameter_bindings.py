"""Every binding covers every parameter. The library's table (``balloon_param_info``, from
``PARAMETERS`` in src/balloon/params.rs) is the list: the C struct BalloonParams in
include/balloonseg.h, the Python package's ctypes struct, both VTK filters and the command line
must each offer all of it, under the names it gives. A parameter added to the library and missed
by a binding fails here; docs/interfaces.md's table is checked by the Rust tests."""

import ctypes
import math
import re

import numpy as np
import pytest
from conftest import REPO, run_cli

import balloonseg
from balloonseg import _library as L


def header_fields() -> list[str]:
    header = (REPO / "include" / "balloonseg.h").read_text()
    body = re.search(r"typedef struct BalloonParams \{(.*?)\} BalloonParams;", header, re.S)
    assert body, "no BalloonParams in the header"
    fields = re.findall(r"^\s*[\w ]+?\s(\w+);", body.group(1), re.M)
    assert fields[0] == "struct_size"
    return fields[1:]


def camel(field: str) -> str:
    return "".join(part.capitalize() for part in field.split("_"))


def test_the_table_is_the_header_s_struct():
    assert list(balloonseg.parameter_info()) == header_fields()
    assert len(header_fields()) >= 13


def test_python_declares_every_field_in_order_with_its_kind():
    assert [name for name, _ in L.BalloonParams._fields_][1:] == header_fields()
    info = balloonseg.parameter_info()
    assert {name: kind for name, kind in balloonseg.PARAMETERS.items()} == {
        name: p.type for name, p in info.items()
    }


@pytest.mark.parametrize("name", list(balloonseg.PARAMETERS))
def test_setting_by_name_reaches_the_field_of_that_name(name):
    """The C ABI's C-to-Rust conversion and the table agree field by field: a value set by name
    lands in the ctypes field of that name, and the defaults are the table's."""
    p = balloonseg.parameter_info()[name]
    params = L.BalloonParams()
    L.check(L.library().balloon_params_default(ctypes.byref(params)))
    default = getattr(params, name)
    assert (math.isnan(default) and math.isnan(p.default)) or default == p.default
    step = 1 if p.type is int else 1.25
    value = p.minimum + step if math.isfinite(p.minimum) else -7.0
    value = min(value, p.maximum)
    assert value != default
    L.check(L.library().balloon_params_set(ctypes.byref(params), name.encode(), value))
    assert getattr(params, name) == value
    others = {n: getattr(params, n) for n in balloonseg.PARAMETERS if n != name}
    fresh = balloonseg.default_params()
    assert all(
        v == fresh[n] or (math.isnan(v) and math.isnan(fresh[n])) for n, v in others.items()
    ), "setting one parameter changed another"


def test_out_of_range_values_are_refused_with_the_range():
    message = r"step_fraction is 2; give a finite number in \(0, 1\]"
    with pytest.raises(balloonseg.InvalidArgumentError, match=message):
        balloonseg.segment(np.zeros((4, 4, 4)), (1, 1, 1), step_fraction=2)


def test_the_python_vtk_filter_sets_every_field():
    from balloonseg.vtk import FILTER_PARAMETERS

    assert FILTER_PARAMETERS == {camel(f): f for f in header_fields()}


def test_the_cpp_vtk_filter_sets_and_gets_every_field():
    """One vtkBalloonParameterMacro(Name, field, type) line per field: the setter writes the
    field of that name in the BalloonParams the filter hands to the library."""
    header = (REPO / "cmake" / "vtk" / "vtkBalloonSegmentation.h").read_text()
    declared = re.findall(r"^\s*vtkBalloonParameterMacro\((\w+), (\w+), [\w ]+\);", header, re.M)
    assert dict(declared) == {camel(f): f for f in header_fields()}
    assert len(declared) == len(header_fields()), "a field declared twice"


def test_the_command_line_has_the_table_s_flag_for_every_field(cli):
    help_text = run_cli(cli, "segment", "--help") + run_cli(cli, "--help")
    for name, p in balloonseg.parameter_info().items():
        assert re.search(rf"\s--{re.escape(p.flag)}\b", help_text), f"no --{p.flag} ({name})"
