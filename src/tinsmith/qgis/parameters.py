"""The registry's method options as QGIS Processing parameters, and the values a run gives them back as keywords.

Every option of every registered method (:func:`tinsmith.methods`) becomes
one parameter named the QGIS way (``min_angle`` -> ``MIN_ANGLE``), so a new
method, or a new option, shows in the toolbox with no code here:

- numbers, whole numbers, switches and choices (an enum of static strings:
  the value's own name is accepted) as advanced parameters, with no default
  of their own: a method's default applies unless the user sets one;
- lines, points and polygons as vector layers; ``regions`` as a polygon layer
  whose fields ``max_area`` and ``name`` give each area's limit and name;
- raster options as raster layers on the input's grid;
- free-form options (``time_step``: a number or ``"auto"``) as text, read as
  a number, a list or the word itself.
"""

from __future__ import annotations

import ast

from qgis.core import (
    QgsProcessing,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
)

from ..algorithms.declaration import STOP_RULES

__all__ = ["REGION_FIELDS", "add_options", "foreign_options", "method_kwargs", "parameter_name", "registry_options"]

#: The fields of a regions layer, in the order of the API's (polygon, max_area, name) items.
REGION_FIELDS = ("max_area", "name")

_GEOMETRY_TYPES = {
    "lines": QgsProcessing.TypeVectorLine,
    "points": QgsProcessing.TypeVectorPoint,
    "polygons": QgsProcessing.TypeVectorPolygon,
    "regions": QgsProcessing.TypeVectorPolygon,
}


def parameter_name(option: str) -> str:
    """``min_angle`` -> ``MIN_ANGLE``."""
    return option.upper()


def registry_options(records) -> dict:
    """name -> (Option, [names of the methods that take it]) over ``records``: one entry per option name, stop
    rules and deprecated names left out."""
    seen: dict = {}
    for record in records:
        for opt in record.options:
            if opt.replaced_by or opt.name in STOP_RULES:
                continue
            seen.setdefault(opt.name, (opt, []))[1].append(record.name)
    return seen


def _parameter(opt, label: str):
    name = parameter_name(opt.name)
    if opt.kind in _GEOMETRY_TYPES:
        return QgsProcessingParameterFeatureSource(name, label, [_GEOMETRY_TYPES[opt.kind]], optional=True)
    if opt.kind == "raster":
        return QgsProcessingParameterRasterLayer(name, label, optional=True)
    if opt.type is bool:
        return QgsProcessingParameterBoolean(name, label, defaultValue=opt.default, optional=True)
    if opt.type in (int, float):
        kind = QgsProcessingParameterNumber.Integer if opt.type is int else QgsProcessingParameterNumber.Double
        parameter = QgsProcessingParameterNumber(name, label, kind, optional=True)
        if opt.minimum is not None:
            parameter.setMinimum(opt.minimum)
        if opt.maximum is not None:
            parameter.setMaximum(opt.maximum)
        return parameter
    if opt.type is str and opt.choices:
        return QgsProcessingParameterEnum(name, label, options=list(opt.choices), optional=True, usesStaticStrings=True)
    return QgsProcessingParameterString(name, label, optional=True)


def add_options(algorithm, options: dict, *, advanced: bool = True) -> None:
    """Add a parameter for every option of :func:`registry_options` to ``algorithm`` (its help: which methods take
    it, what it does, its default)."""
    for opt, owners in options.values():
        label = opt.name.replace("_", " ").capitalize() + (f" [{', '.join(owners)}]" if len(owners) < 4 else "")
        parameter = _parameter(opt, label)
        parameter.setHelp(f"[{', '.join(owners)}] {opt.describe()}")
        if advanced and opt.kind == "value":
            parameter.setFlags(parameter.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
        algorithm.addParameter(parameter)


def _literal(text: str):
    """A free-form option's text as a Python value: a number, a list, ... or the text itself (``auto``)."""
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def method_kwargs(algorithm, record, parameters, context, hf_crs: str | None, read_raster) -> dict:
    """The options of method ``record`` the run gives, as keywords of the API (geometries in ``hf_crs``;
    ``read_raster(name)`` reads a raster option)."""
    kwargs = {}
    for opt in record.options:
        if opt.replaced_by or opt.name in STOP_RULES:
            continue
        name = parameter_name(opt.name)
        if parameters.get(name) in (None, ""):
            continue
        if opt.kind in _GEOMETRY_TYPES:
            fields = REGION_FIELDS if opt.kind == "regions" else ()
            value = algorithm.geometries(parameters, name, context, hf_crs, fields)
        elif opt.kind == "raster":
            value = read_raster(name)
        elif opt.type is bool:
            value = algorithm.parameterAsBool(parameters, name, context)
            if value == opt.default:
                continue
        elif opt.type is int:
            value = algorithm.parameterAsInt(parameters, name, context)
        elif opt.type is float:
            value = algorithm.parameterAsDouble(parameters, name, context)
        elif opt.type is str and opt.choices:
            value = algorithm.parameterAsEnumString(parameters, name, context)
        else:
            value = _literal(algorithm.parameterAsString(parameters, name, context))
        if value is not None:
            kwargs[opt.name] = value
    return kwargs


def foreign_options(record, options: dict, parameters) -> list[str]:
    """The parameters of :func:`registry_options` the run sets that method ``record`` does not take (a switch at
    its default is not set)."""
    taken = {opt.name for opt in record.options}
    return [parameter_name(name) for name, (opt, _) in options.items()
            if name not in taken and parameters.get(parameter_name(name)) not in (None, "")
            and not (opt.type is bool and parameters.get(parameter_name(name)) == opt.default)]
