"""The packaged FMU passes fmpy's validation and says what the contract and the variable table say."""

import tomllib
import zipfile

from fmpy.validation import validate_fmu

from conftest import REPO

CONTRACT_OUTPUTS = ["x", "v", "p", "Q1", "Q2", "u1", "u2", "x_ref", "e_x", "F_cyl", "P_hyd1", "P_hyd2"]


def table():
    with open(REPO / "modelDescription" / "variables.toml", "rb") as f:
        return tomllib.load(f)


def test_fmpy_validate_reports_no_problem(fmu_path):
    problems = validate_fmu(str(fmu_path))
    assert problems == [], "fmpy.validate_fmu found problems:\n" + "\n".join(problems)


def test_archive_layout(fmu_path):
    names = zipfile.ZipFile(fmu_path).namelist()
    assert "modelDescription.xml" in names, names
    assert "binaries/linux64/tbm_thrust.so" in names, f"no linux64 binary in {names}"
    assert not any("\\" in n for n in names), f"backslash in zip paths: {names}"


def test_co_simulation_capabilities(fmu):
    md = fmu.md
    assert md.fmiVersion == "2.0"
    assert md.modelExchange is None, "the FMU is Co-Simulation only"
    cs = md.coSimulation
    assert cs.modelIdentifier == "tbm_thrust"
    assert cs.canHandleVariableCommunicationStepSize, "canHandleVariableCommunicationStepSize must be true"
    assert cs.canGetAndSetFMUstate, "canGetAndSetFMUstate must be true"
    assert cs.canSerializeFMUstate, "canSerializeFMUstate must be true"
    assert not cs.canBeInstantiatedOnlyOncePerProcess, "several instances per process must be allowed"


def test_variables_match_the_table_and_the_contract(fmu):
    t = table()
    want = {}
    for group in ("inputs", "outputs", "parameters"):
        for v in t[group]:
            want[v["name"]] = (v["vr"], group[:-1])
    got = {name: (var.valueReference, var.causality) for name, var in fmu.variables.items() if var.causality != "independent"}
    missing = sorted(set(want) - set(got))
    assert not missing, f"variables of modelDescription/variables.toml missing from the FMU: {missing}"
    wrong = {n: (got[n], want[n]) for n in want if got[n] != want[n]}
    assert not wrong, f"value reference or causality differs from the table (got, table): {wrong}"
    assert set(CONTRACT_OUTPUTS) <= set(fmu.outputs), f"contract outputs missing: {set(CONTRACT_OUTPUTS) - set(fmu.outputs)}"
    assert set(fmu.inputs) == {"v_ref", "F_L"}, f"inputs: {fmu.inputs}"
    for name in ("scheme", "controller"):
        v = fmu.variables[name]
        assert v.type == "Enumeration" and v.variability == "fixed", f"{name}: {v.type} {v.variability}"
    assert [i.name for i in fmu.variables["scheme"].declaredType.items] == ["single", "fixed_split", "adaptive"]
    assert [i.name for i in fmu.variables["controller"].declaredType.items] == ["pid", "adrc"]
    assert fmu.variables["scheme"].start in ("3", 3), "default scheme must be adaptive"
    assert fmu.variables["controller"].start in ("1", 1), "default controller must be pid"
    assert float(fmu.variables["F_L"].start) == 12000.0, "F_L start must be the paper's 12 kN"


def test_units_and_descriptions(fmu):
    t = table()
    units = {v["name"]: v.get("unit", "") for g in ("inputs", "outputs", "parameters") for v in t[g] if "unit" in v}
    for name, unit in units.items():
        if unit:
            assert fmu.variables[name].unit == unit, f"{name}: unit {fmu.variables[name].unit!r}, table {unit!r}"
    undocumented = [n for n, v in fmu.variables.items() if v.causality != "independent" and not v.description]
    assert not undocumented, f"variables without a description: {undocumented}"


def test_log_categories_declared(fmu):
    declared = set(fmu.md.logCategories) if isinstance(fmu.md.logCategories, dict) else {c.name for c in fmu.md.logCategories}
    want = {c["name"] for c in table()["log_categories"]}
    assert want <= declared, f"log categories missing from modelDescription: {want - declared}"
