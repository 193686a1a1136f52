"""Bad Python input is an InputError, never a crash (issue 36): cyclic and
deep dicts, every scalar type, integers out of range, paths apart from TOML
text."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import from_dtype

import bellyflop

TYPES = {"Scenario": bellyflop.Scenario, "SimConfig": bellyflop.SimConfig}


def base_dict(kind: str) -> dict:
    return bellyflop.Scenario.paper().to_dict() if kind == "Scenario" else bellyflop.SimConfig().to_dict()


def deep_list(depth: int):
    v: list = []
    for _ in range(depth - 1):
        v = [v]
    return v


def deep_dict(depth: int):
    v: dict = {}
    for _ in range(depth - 1):
        v = {"a": v}
    return v


# The five inputs that ended the interpreter with SIGSEGV, and two more;
# run in a child process so that, before the fix, the crash fails this test
# instead of ending the test run.
CRASHERS = textwrap.dedent(
    """
    import sys, bellyflop
    kind = getattr(bellyflop, sys.argv[1])
    def deep_list(n):
        v = []
        for _ in range(n - 1):
            v = [v]
        return v
    def deep_dict(n):
        v = {}
        for _ in range(n - 1):
            v = {"a": v}
        return v
    cyclic_dict = {}
    cyclic_dict["self"] = cyclic_dict
    cyclic_list = []
    cyclic_list.append(cyclic_list)
    nested = {"initial": {"x_m": [1.0, 2.0, 3.0, cyclic_list]}}
    for name, value in [
        ("cyclic dict", cyclic_dict),
        ("cyclic list", {"initial": cyclic_list}),
        ("deep dict", deep_dict(100_000)),
        ("deep list", {"initial": deep_list(100_000)}),
        ("deep top-level list", deep_list(100_000)),
        ("cycle inside a list", nested),
        ("deep and wide", {"a": [deep_dict(50_000), deep_list(50_000)]}),
    ]:
        try:
            kind.from_dict(value)
            print(name, "accepted")
        except bellyflop.InputError as e:
            print(name, "InputError:", e)
    """
)


@pytest.mark.parametrize("kind", list(TYPES))
def test_cycles_and_depth_do_not_crash(kind):
    p = subprocess.run([sys.executable, "-c", CRASHERS, kind], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, (p.returncode, p.stderr[-2000:])
    lines = p.stdout.splitlines()
    assert len(lines) == 7 and all("InputError" in line for line in lines), p.stdout


@pytest.mark.parametrize("kind", list(TYPES))
def test_the_error_names_the_key_path(kind):
    cls = TYPES[kind]
    d = base_dict(kind)
    section = next(k for k, v in d.items() if isinstance(v, dict))
    cyc: list = [1.0, 2.0, 3.0]
    cyc.append(cyc)
    d[section]["x_m"] = cyc
    with pytest.raises(bellyflop.InputError, match=rf"{section}\.x_m\[3\]: a cycle"):
        cls.from_dict(d)
    d = base_dict(kind)
    d[section]["deep"] = deep_list(10**5)
    with pytest.raises(bellyflop.InputError, match=rf"{section}\.deep(\[0\])+: nested deeper than 64"):
        cls.from_dict(d)
    d = {"loop": {}}
    d["loop"]["back"] = d
    with pytest.raises(bellyflop.InputError, match=r"loop\.back: a cycle"):
        cls.from_dict(d)


def test_shared_but_acyclic_values_are_fine():
    # One list under two keys is not a cycle: the error is the unknown key.
    d = bellyflop.Scenario.paper().to_dict()
    shared = [1.0, 2.0]
    d["initial"]["extra_a"] = shared
    d["initial"]["extra_b"] = shared
    with pytest.raises(bellyflop.InputError) as e:
        bellyflop.Scenario.from_dict(d)
    assert "extra_a" in str(e.value) and "cycle" not in str(e.value)
    d = bellyflop.Scenario.paper().to_dict()
    d["terminal"] = d["terminal"]
    assert bellyflop.Scenario.from_dict(d) == bellyflop.Scenario.paper()


def test_numpy_scalars_are_numbers():
    d = bellyflop.Scenario.paper().to_dict()
    d["initial"]["mass_kg"] = np.float32(120_000.0)
    d["initial"]["z_m"] = np.int64(int(d["initial"]["z_m"]))
    d["discretization"]["nodes"] = np.uint8(20)
    assert bellyflop.Scenario.from_dict(d) == bellyflop.Scenario.paper()
    d["discretization"]["nodes"] = 2**70
    with pytest.raises(bellyflop.InputError, match=r"discretization\.nodes: the integer 1180591620717411303424 is out of range"):
        bellyflop.Scenario.from_dict(d)
    d["discretization"]["nodes"] = np.complex128(1 + 2j)
    with pytest.raises(bellyflop.InputError, match=r"discretization\.nodes: cannot use a complex128"):
        bellyflop.Scenario.from_dict(d)
    with pytest.raises(bellyflop.InputError, match=r"keys must be str, got 3"):
        bellyflop.Scenario.from_dict({3: 1})


# --- property-based: any value anywhere is a Scenario/SimConfig or an InputError

NUMPY_DTYPES = [
    "bool", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "uint64",
    "float16", "float32", "float64", "longdouble", "complex64", "complex128",
    "U8", "S8", "datetime64[s]", "timedelta64[ms]",
]

python_scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),  # unbounded: beyond 2**64 too
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([float("nan"), float("inf"), float("-inf"), -0.0, 2**64, -(2**64), 2**63]),
    st.text(max_size=6),
    st.binary(max_size=4),
    st.complex_numbers(allow_nan=True),
    st.decimals(allow_nan=True),
    st.fractions(),
)
numpy_scalars = st.sampled_from(NUMPY_DTYPES).flatmap(lambda t: from_dtype(np.dtype(t)))
scalars = st.one_of(python_scalars, numpy_scalars)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=3),
        st.lists(inner, max_size=3).map(tuple),
        st.dictionaries(st.text(max_size=4), inner, max_size=3),
    ),
    max_leaves=6,
)

EXAMPLES = int(os.environ.get("BELLYFLOP_HYPOTHESIS_EXAMPLES", "10000"))


def structured(kind: str):
    """The type's own dict with one key replaced (or added, or removed),
    a whole table replaced, a cycle or a deep nest put in, or any value."""
    base = base_dict(kind)
    sections = [k for k, v in base.items() if isinstance(v, dict)]

    def replace_key(args):
        section, key, value, drop = args
        d = base_dict(kind)
        keys = list(d[section]) if isinstance(d[section], dict) else []
        name = keys[key % len(keys)] if keys and key >= 0 else f"no_such_{key}"
        if drop:
            d[section].pop(name, None)
        else:
            d[section][name] = value
        return d

    def cycle(args):
        section, as_list = args
        d = base_dict(kind)
        loop: list = [1.0]
        loop.append(loop)
        d[section]["loop"] = loop if as_list else d
        return d

    def deep(args):
        section, depth, as_list = args
        d = base_dict(kind)
        d[section]["deep"] = deep_list(depth) if as_list else deep_dict(depth)
        return d

    def replace_section(args):
        section, value = args
        d = base_dict(kind)
        d[section] = value
        return d

    s = st.sampled_from(sections)
    return st.one_of(
        st.tuples(s, st.integers(-1, 40), values, st.booleans()).map(replace_key),
        st.tuples(st.sampled_from(list(base)), values).map(replace_section),
        st.tuples(s, st.booleans()).map(cycle),
        st.tuples(s, st.sampled_from([63, 64, 65, 1000, 10**5]), st.booleans()).map(deep),
        values,
    )


def check_from_dict(kind: str, d) -> None:
    cls = TYPES[kind]
    try:
        v = cls.from_dict(d)
    except bellyflop.InputError as e:
        assert str(e)
        return
    # Accepted: a valid value that reads back to itself.
    assert cls.from_dict(v.to_dict()).to_toml() == v.to_toml()


@pytest.mark.big
@pytest.mark.parametrize("kind", list(TYPES))
def test_from_dict_any_value(kind):
    start = time.perf_counter()
    count = [0]

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=True,  # seeded: the same examples on every run
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(structured(kind))
    def run(d):
        count[0] += 1
        check_from_dict(kind, d)

    run()
    elapsed = time.perf_counter() - start
    print(f"{kind}.from_dict: {count[0]} examples in {elapsed:.1f} s")
    assert count[0] >= min(EXAMPLES, 10_000) or EXAMPLES < 10_000


# --- integer arguments: InputError naming the argument, value and range

U64_MAX = 2**64 - 1


@pytest.mark.parametrize(
    "call,name,value,allowed",
    [
        (lambda v: bellyflop.solve(nodes=v), "nodes", -1, "4 to 200"),
        (lambda v: bellyflop.solve(nodes=v), "nodes", 2**64, "4 to 200"),
        (lambda v: bellyflop.solve(intervals=v), "intervals", -3, "1 to 50"),
        (lambda v: bellyflop.solve(intervals=v), "intervals", 2**70, "1 to 50"),
        (lambda v: bellyflop.sim(seed=v), "seed", -1, f"0 to {U64_MAX}"),
        (lambda v: bellyflop.sim(seed=v), "seed", 2**64, f"0 to {U64_MAX}"),
        (lambda v: bellyflop.sim(run=v), "run", -5, f"0 to {U64_MAX}"),
        (lambda v: bellyflop.sim(run=v), "run", 2**65, f"0 to {U64_MAX}"),
        (lambda v: bellyflop.montecarlo(2, seed=v), "seed", -1, f"0 to {U64_MAX}"),
        (lambda v: bellyflop.montecarlo(2, threads=v), "threads", -1, "0 to 1000000"),
        (lambda v: bellyflop.montecarlo(2, threads=v), "threads", 2**64, "0 to 1000000"),
        (lambda v: bellyflop.montecarlo(v), "runs", 2**64, "1 to 1000000"),
    ],
)
def test_integer_out_of_range(call, name, value, allowed):
    with pytest.raises(bellyflop.InputError, match=rf"^{name} = {value} is out of range: allowed {allowed}$"):
        call(value)


def test_integer_arguments_of_other_types():
    with pytest.raises(bellyflop.InputError, match=r"nodes = 2\.5 is not an integer"):
        bellyflop.solve(nodes=2.5)
    with pytest.raises(bellyflop.InputError, match=r"seed = True is not an integer"):
        bellyflop.sim(seed=True)
    # numpy integers are integers.
    assert bellyflop.sim(seed=np.uint64(3), run=np.int32(2)).row["run"] == 2


# --- paths apart from TOML text


def test_from_toml_takes_a_path_even_with_equals(tmp_path):
    d = tmp_path / "a=b" / "x = 1"
    d.mkdir(parents=True)
    p = d / "case=1.toml"
    p.write_text(bellyflop.Scenario.paper().to_toml())
    c = d / "config=2.toml"
    c.write_text(bellyflop.SimConfig().to_toml())
    for arg in (p, str(p)):
        assert bellyflop.Scenario.from_toml(arg) == bellyflop.Scenario.paper()
        assert bellyflop.solve(arg, fast=True).final_mass_kg == bellyflop.solve(fast=True).final_mass_kg
    for arg in (c, str(c)):
        assert bellyflop.SimConfig.from_toml(arg) == bellyflop.SimConfig()


@pytest.mark.parametrize("kind", list(TYPES))
def test_from_toml_never_parses_its_argument(kind, tmp_path):
    cls = TYPES[kind]
    text = cls.paper().to_toml() if kind == "Scenario" else "[guidance]\nreplan = true\n"
    with pytest.raises((bellyflop.InputError, FileNotFoundError)) as e:
        cls.from_toml(text)
    assert "TOML, line" not in str(e.value)
    missing = tmp_path / "no" / "such=file.toml"
    with pytest.raises((bellyflop.InputError, FileNotFoundError), match=re.escape(str(missing))):
        cls.from_toml(missing)
    assert cls.from_toml_text(text) == cls.from_toml_text(cls.from_toml_text(text).to_toml())
    with pytest.raises(TypeError):
        cls.from_toml(3)
