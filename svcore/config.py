"""One configuration mechanism for every command: declared with pydantic, loaded from params.yaml and ``--set``.

A stage's configuration is a :class:`ConfigModel` subclass: typed fields, each documented by the attribute
docstring under it (that docstring is the ``--help`` text and the params.yaml documentation), range limits as
``Field(ge=..)``, cross-field rules as a ``model_validator``, and its named presets in the class body
(``PRESETS``; nothing registers itself on import). One resolution order everywhere::

    class defaults < preset < params.yaml section < --set KEY=VALUE < the command's own flags

Why pydantic (v2, already a dependency of the stack): strict types for free (``true`` is not an integer,
``"0.25"`` is not a number), nested sections, field descriptions from attribute docstrings, and errors that
carry the key and the offending value, which become one line here. A hand-written dataclass coercer did
this in two incompatible ways before (pipeline and train); OmegaConf has no strict booleans-vs-ints and
tyro would replace click.

Type conversion, the same for every source: values are YAML values. params.yaml is read with YAML 1.2
number rules (``1e-3`` is a float; PyYAML's YAML 1.1 would read it as a string), and a ``--set`` value is
parsed as one YAML scalar or flow collection (``--set optim.lr=1e-3``, ``--set materials=[a, b]``,
``--set data.store=null``). Then the types are strict: a quoted number (``sigma: "0.25"``) is a string and
is refused with a one-line error naming the key, since quoting it was asked for. Integers are accepted where
a float is expected; nothing else is converted.

An empty ``params.yaml``, or one without the command's section, is not an error but says so in one warning
line: the defaults run (the project's params file holds every stage's section, and a command may be run before
its section exists). Any other params file (a run's ``config.yaml``, an experiment's own file) was given for this
command: a missing section there is an error. Unknown keys are errors.
"""
from __future__ import annotations

import re
import types
import typing
from pathlib import Path
from typing import Any, ClassVar, Literal, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, PrivateAttr, ValidationError

from .errors import ConfigError
from .log import get_logger

log = get_logger(__name__)

C = TypeVar("C", bound="ConfigModel")

#: the key (in a params.yaml section or ``--set``) and flag that select a named preset, on every command.
PRESET_KEY = "config_preset"
PRESET_FLAG = "--config-preset"


class ConfigModel(BaseModel):
    """Base of every command's configuration.

    Class attributes of a subclass:
        SECTION: its params.yaml section ("sample", "train" ...).
        PRESETS: preset name -> values (nested dicts for nested sections), applied over the class defaults.
        DEFAULT_PRESET: the preset used when none is named.
    """

    model_config = ConfigDict(strict=True, extra="forbid", use_attribute_docstrings=True, validate_assignment=True,
                              validate_default=True)

    SECTION: ClassVar[str] = ""
    PRESETS: ClassVar[dict[str, dict[str, Any]]] = {"default": {}}
    DEFAULT_PRESET: ClassVar[str] = "default"

    _preset: str = PrivateAttr(default="")

    @property
    def preset(self) -> str:
        """The preset this config was resolved from (informational: not a config key, not in :meth:`as_dict`)."""
        return self._preset

    @classmethod
    def stored(cls, values: dict[str, Any]) -> dict[str, Any]:
        """A params file's section (nested mappings) as this config reads it: a config that retired keys drops them
        here, so that files written before still load (``--set`` and flags never pass through). Default: as is."""
        return values

    def as_dict(self) -> dict[str, Any]:
        """JSON-able values (tuples as lists), in field order: what stores and runs record."""
        return self.model_dump(mode="json")

    def to_dict(self) -> dict[str, Any]:
        return self.as_dict()


# -- YAML: one reader for files and --set values -----------------------------------------------------------
class _Yaml12Loader(yaml.SafeLoader):
    """SafeLoader with YAML 1.2 floats: ``1e-3`` and ``2E5`` are numbers, as in every other YAML/JSON reader."""


_FLOAT = re.compile(r"^[-+]?(?:[0-9][0-9_]*\.[0-9_]*(?:[eE][-+]?[0-9]+)?|\.[0-9_]+(?:[eE][-+]?[0-9]+)?"
                    r"|[0-9][0-9_]*[eE][-+]?[0-9]+|\.(?:inf|Inf|INF)|[-+]\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$")
_Yaml12Loader.yaml_implicit_resolvers = {k: [r for r in v if r[0] != "tag:yaml.org,2002:float"]
                                        for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_Yaml12Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))


def read_yaml(path: str | Path) -> Any:
    """Parse a YAML file with :class:`_Yaml12Loader`; a missing or malformed file is a one-line ConfigError."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"params file {p} does not exist")
    try:
        return yaml.load(p.read_text(), Loader=_Yaml12Loader)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ConfigError(f"params file {p} is not valid YAML{where}: {getattr(e, 'problem', None) or e}") from None


def parse_value(text: str) -> Any:
    """A ``--set`` value as the YAML scalar or flow collection it spells (``0.25``, ``true``, ``[a, b]``, ``null``)."""
    try:
        return yaml.load(text, Loader=_Yaml12Loader) if text.strip() else None
    except yaml.YAMLError:
        return text  # not YAML (e.g. "a: b: c"): a plain string, which strict typing then judges


def parse_sets(items: typing.Iterable[str]) -> dict[str, Any]:
    """``["model.base_width=32", ...]`` -> ``{"model.base_width": 32}`` (values parsed by :func:`parse_value`)."""
    out = {}
    for it in items:
        key, sep, val = it.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"--set {it!r} is not KEY=VALUE (e.g. --set seed=3)")
        out[key.strip()] = parse_value(val.strip())
    return out


#: the file name of the project's params file (DVC's): the one params file whose missing section is only a warning
PROJECT_PARAMS = "params.yaml"


def params_section(path: str | Path, section: str) -> dict[str, Any]:
    """The ``section`` mapping of a params file; for the project's ``params.yaml``, ``{}`` (with a warning line)
    when the file or section is empty.

    Raises:
        ConfigError: missing or malformed file, a top level that is not a mapping, a section that is not one; an
            empty or missing section in a file other than ``params.yaml``.
    """
    doc = read_yaml(path)
    if doc is not None and not isinstance(doc, dict):
        raise ConfigError(f"params file {path}: the top level must be a mapping of sections (sample:, render: ...), "
                          f"got a {type(doc).__name__}")
    if doc is None or doc.get(section) is None:
        what = "is empty" if doc is None else f"has no '{section}' section"
        if Path(path).name != PROJECT_PARAMS:
            found = f" (it has {', '.join(map(str, doc))})" if doc else ""
            raise ConfigError(f"params file {path} {what}{found}: a params file for this command needs a "
                              f"'{section}:' section (--print-config writes one)")
        log.warning("params file %s %s: %s runs with its defaults", path, what, section)
        return {}
    sec = doc[section]
    if not isinstance(sec, dict):
        raise ConfigError(f"params file {path}: section '{section}' must be a mapping of keys, "
                          f"got a {type(sec).__name__}")
    return dict(sec)


def params_text(cfg: ConfigModel) -> str:
    """A resolved config as a params file (``SECTION:`` and every key): what ``--print-config`` prints and a run
    records, and what ``--params`` reads back to the same config."""
    return yaml.safe_dump({cfg.SECTION: cfg.as_dict()}, sort_keys=False)


# -- merging and validation --------------------------------------------------------------------------------
def nest(flat: dict[str, Any]) -> dict[str, Any]:
    """``{"model.base_width": 32, "optim": {"lr": 1}}`` -> ``{"model": {"base_width": 32}, "optim": {"lr": 1}}``."""
    out: dict[str, Any] = {}
    for key, val in flat.items():
        head, _, rest = key.partition(".")
        if rest:
            sub = out.setdefault(head, {})
            if not isinstance(sub, dict):
                raise ConfigError(f"config key {head!r} is a value, not a section: cannot set {key!r}")
            merge(sub, nest({rest: val}))
        elif isinstance(val, dict) and isinstance(out.get(head), dict):
            merge(out[head], nest(val))
        else:
            out[head] = nest(val) if isinstance(val, dict) else val
    return out


def merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """Deep-merge ``over`` into ``base`` (in place; sections merge, values replace). Returns base."""
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(base.get(k), dict):
            merge(base[k], v)
        else:
            base[k] = v
    return base


def _describe(err: dict, section: str) -> str:
    key = ".".join([section, *map(str, err["loc"])]) if section else ".".join(map(str, err["loc"]))
    t, ctx, val = err["type"], err.get("ctx", {}), err.get("input")
    if t == "extra_forbidden":
        return f"unknown config key {key!r}"
    if t == "value_error" or not err["loc"]:  # a model_validator's rule: its own words
        msg = str(ctx.get("error", err["msg"])).removeprefix("Value error, ")
        return f"{section}: {msg}" if section and not err["loc"] else f"{key}: {msg}"
    expect = {"int_type": "an integer", "float_type": "a number", "bool_type": "true or false",
              "string_type": "a string", "tuple_type": "a list", "list_type": "a list", "model_type": "a mapping",
              "dict_type": "a mapping", "literal_error": f"one of {ctx.get('expected')}",
              "greater_than_equal": f">= {ctx.get('ge')}", "greater_than": f"> {ctx.get('gt')}",
              "less_than_equal": f"<= {ctx.get('le')}", "less_than": f"< {ctx.get('lt')}",
              "none_required": "null"}.get(t)
    if t == "model_type":
        return f"config key {key!r} is a section: give its keys as a mapping, got {val!r}"
    msg = f"{key} must be {expect}" if expect else f"{key}: {err['msg']}"
    hint = ""
    if isinstance(val, str) and t in ("int_type", "float_type", "bool_type") and \
            not isinstance(parse_value(val), str):  # only a value that unquoted would be a number or a boolean
        hint = " (a quoted value is a string: write it without quotes)"
    return f"{msg}, got {val!r}{hint}"


def validate(cls: type[C], values: dict[str, Any], section: str | None = None) -> C:
    """``cls(**values)`` with every problem as one ConfigError line naming the keys (``sample.sigma ...``)."""
    try:
        return cls.model_validate(values)
    except ValidationError as e:
        sec = cls.SECTION if section is None else section
        raise ConfigError("; ".join(_describe(err, sec) for err in e.errors())) from None


def resolve(cls: type[C], preset: str | None = None, params_file: str | Path | None = None,
            sets: dict[str, Any] | None = None, flags: dict[str, Any] | None = None) -> C:
    """The configuration of one command run.

    Args:
        cls: the command's :class:`ConfigModel`.
        preset: the preset named by the command line (``--config-preset``); else one named by ``--set
            config_preset=..`` or the params section's ``config_preset:`` key; else ``cls.DEFAULT_PRESET``.
        params_file: a params.yaml whose ``cls.SECTION`` fills the config.
        sets: ``--set`` values by dotted key (already parsed, see :func:`parse_sets`).
        flags: the command's own flags by dotted key; None values (flag not given) are skipped.

    Raises:
        ConfigError: unknown preset or key, a wrongly typed or out-of-range value (one line, naming the key).
    """
    section = params_section(params_file, cls.SECTION) if params_file is not None else {}
    sets = dict(sets or {})
    name = preset or sets.pop(PRESET_KEY, None) or section.pop(PRESET_KEY, None) or cls.DEFAULT_PRESET
    section.pop(PRESET_KEY, None)
    if name not in cls.PRESETS:
        raise ConfigError(f"unknown config preset {name!r} for {cls.SECTION}; known: {', '.join(cls.PRESETS)}")
    values = nest(cls.PRESETS[name])
    merge(values, cls.stored(nest(section)))
    merge(values, nest(sets))
    merge(values, nest({k: v for k, v in (flags or {}).items() if v is not None}))
    cfg = validate(cls, values)
    cfg._preset = name
    return cfg


def build(cls: type[C], preset: str | None = None, params_file: str | Path | None = None, **values) -> C:
    """Python callers' shortcut: ``build(SampleConfig, "tiny", size=64)`` (keyword values win; None skipped)."""
    return resolve(cls, preset, params_file, flags=values)


# -- introspection: help texts and the list of keys --------------------------------------------------------
def _unwrap(ann: Any) -> Any:
    """``X | None`` -> X."""
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(ann) if a is not type(None)]
        return args[0] if len(args) == 1 else ann
    return ann


def type_name(ann: Any) -> str:
    """Short name of a field type for help texts: int, float, bool, str, one of a|b, list of str, ..."""
    optional = typing.get_origin(ann) in (typing.Union, types.UnionType) and type(None) in typing.get_args(ann)
    ann = _unwrap(ann)
    if typing.get_origin(ann) is Literal:
        name = "|".join(map(str, typing.get_args(ann)))
    elif typing.get_origin(ann) in (tuple, list):
        name = "list of " + type_name(typing.get_args(ann)[0])
    else:
        name = getattr(ann, "__name__", str(ann))
    return name + " or null" if optional else name


def keys(cls: type[ConfigModel], prefix: str = "") -> list[tuple[str, Any, Any, str]]:
    """Every settable key of a config: (dotted key, annotation, default, description), nested sections flattened."""
    out = []
    for name, f in cls.model_fields.items():
        ann = f.annotation
        if isinstance(ann, type) and issubclass(ann, ConfigModel):
            out += keys(ann, prefix + name + ".")
            continue
        out.append((prefix + name, ann, f.get_default(call_default_factory=True), " ".join((f.description or "").split())))
    return out


def field(cls: type[ConfigModel], key: str):
    """The pydantic FieldInfo of a dotted key (``optim.lr``)."""
    head, _, rest = key.partition(".")
    f = cls.model_fields[head]
    return field(f.annotation, rest) if rest else f


def preset_values(cls: type[ConfigModel], name: str | None = None) -> dict[str, Any]:
    """Flat dotted-key values of a preset resolved over the defaults (what ``--help`` shows as defaults)."""
    cfg = validate(cls, nest(cls.PRESETS[name or cls.DEFAULT_PRESET]))

    def flat(d, prefix=""):
        out = {}
        for k, v in d.items():
            out.update(flat(v, prefix + k + ".") if isinstance(v, dict) else {prefix + k: v})
        return out

    return flat(cfg.as_dict())
