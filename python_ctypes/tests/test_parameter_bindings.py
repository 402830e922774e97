"""Every binding covers every parameter: the C struct BalloonParams in include/balloonseg.h
(generated from the Rust C ABI) is the list, and the Python package, both VTK filters and the
command line must each offer all of its fields. A parameter added to the library and missed by
a binding fails here."""

import re

from conftest import REPO, run_cli

import balloonseg
from balloonseg import _library as L

#: The command line's flag for each field; its names are the short ones users type.
CLI_FLAGS = {
    "reference_intensity": "--reference",
    "tolerance": "--tolerance",
    "edge_length_mm": "--edge-length",
    "elastic_weight": "--elastic",
    "bending_weight": "--bending",
    "inflation_weight": "--inflation",
    "step_fraction": "--step-fraction",
    "max_iterations": "--max-iterations",
    "self_intersection_interval": "--self-intersection-interval",
    "refinement_iterations": "--refinement-iterations",
    "max_reparametrizations": "--max-reparametrizations",
    "max_vertices": "--max-vertices",
    "threads": "--threads",
}


def header_fields() -> list[str]:
    header = (REPO / "include" / "balloonseg.h").read_text()
    body = re.search(r"typedef struct BalloonParams \{(.*?)\} BalloonParams;", header, re.S)
    assert body, "no BalloonParams in the header"
    fields = re.findall(r"^\s*[\w ]+?\s(\w+);", body.group(1), re.M)
    assert fields[0] == "struct_size"
    return fields[1:]


def camel(field: str) -> str:
    return "".join(part.capitalize() for part in field.split("_"))


def test_the_header_lists_the_parameters():
    assert len(header_fields()) >= 13


def test_python_declares_every_field_in_order():
    assert [name for name, _ in L.BalloonParams._fields_][1:] == header_fields()
    assert list(balloonseg.PARAMETERS) == header_fields()


def test_the_python_vtk_filter_sets_every_field():
    from balloonseg.vtk import FILTER_PARAMETERS

    assert sorted(FILTER_PARAMETERS.values()) == sorted(header_fields())


def test_the_cpp_vtk_filter_sets_and_gets_every_field():
    header = (REPO / "cmake" / "vtk" / "vtkBalloonSegmentation.h").read_text()
    for field in header_fields():
        name = camel(field)
        setter = rf"(vtkSetMacro\({name},|void Set{name}\()"
        getter = rf"(vtkGetMacro\({name},|Get{name}\(\))"
        assert re.search(setter, header), f"vtkBalloonSegmentation has no Set{name}"
        assert re.search(getter, header), f"vtkBalloonSegmentation has no Get{name}"


def test_the_command_line_has_a_flag_for_every_field(cli):
    assert sorted(CLI_FLAGS) == sorted(header_fields()), "map the new field to its CLI flag"
    help_text = run_cli(cli, "segment", "--help")
    for field, flag in CLI_FLAGS.items():
        assert re.search(rf"\s{re.escape(flag)}\b", help_text), f"segment has no {flag} ({field})"
