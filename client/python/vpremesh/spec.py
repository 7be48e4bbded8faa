"""JobSpec from keyword options: each name is a field of JobSpec or of
PipelineOptions (remesh.proto), looked up in the generated descriptors, so a
field the proto gains is an option at once."""
import os

from google.protobuf.descriptor import FieldDescriptor

from .v1 import remesh_pb2

# Fields the client fills itself.
_SET_BY_CLIENT = {"target_vertices", "mesh_size_bytes", "options"}


def _enum_value(field, value):
    """An enum field takes its number, its value name (DEVICE_CPU) or the name
    without the enum's common prefix, in any case (cpu)."""
    if isinstance(value, int):
        return value
    names = [v.name for v in field.enum_type.values]
    common = os.path.commonprefix(names)
    prefix = common[: common.rfind("_") + 1]  # DEVICE_ of DEVICE_ANY, DEVICE_CPU, ...
    wanted = str(value).upper()
    for candidate in (wanted, prefix + wanted):
        if candidate in field.enum_type.values_by_name:
            return field.enum_type.values_by_name[candidate].number
    short = ", ".join(n[len(prefix):].lower() for n in names)
    raise ValueError(f"{field.name}={value!r}: not one of {short}")


def _set(message, field, name, value):
    if field.label == FieldDescriptor.LABEL_REPEATED:
        container = getattr(message, name)
        del container[:]
        container.extend(value)
    elif field.type == FieldDescriptor.TYPE_ENUM:
        setattr(message, name, _enum_value(field, value))
    else:
        setattr(message, name, value)


def _level(item):
    """One LevelTarget: a vertex count (int), a fraction of the input's
    vertices (float in (0, 1]), or a dict of LevelTarget fields
    ({"min_ssim": 0.97, "screen_px": 200})."""
    if isinstance(item, remesh_pb2.LevelTarget):
        return item
    if isinstance(item, dict):
        return remesh_pb2.LevelTarget(**item)
    if isinstance(item, bool) or not isinstance(item, (int, float)):
        raise TypeError(f"levels: {item!r} is not a vertex count, a fraction or a dict of LevelTarget fields")
    if isinstance(item, int):
        return remesh_pb2.LevelTarget(vertices=item)
    return remesh_pb2.LevelTarget(fraction=item)


def option_names():
    """Every keyword option, sorted."""
    spec = set(remesh_pb2.JobSpec.DESCRIPTOR.fields_by_name) - _SET_BY_CLIENT
    return sorted(spec | set(remesh_pb2.PipelineOptions.DESCRIPTOR.fields_by_name))


def make_spec(target_vertices, size_bytes, options, caller="remesh"):
    """target_vertices may be None with levels=[...] (a level-of-detail chain)."""
    spec = remesh_pb2.JobSpec(target_vertices=target_vertices or 0, mesh_size_bytes=size_bytes)
    spec_fields = remesh_pb2.JobSpec.DESCRIPTOR.fields_by_name
    pipeline_fields = remesh_pb2.PipelineOptions.DESCRIPTOR.fields_by_name
    for name, value in options.items():
        if name in _SET_BY_CLIENT:
            raise TypeError(f"{caller}() sets {name} itself; it is not an option")
        if name == "levels":
            spec.levels.extend(_level(item) for item in value)
        elif name in spec_fields:
            _set(spec, spec_fields[name], name, value)
        elif name in pipeline_fields:
            _set(spec.options, pipeline_fields[name], name, value)
        else:
            raise TypeError(f"{caller}() got an unknown option {name!r}: options are the fields of JobSpec and "
                            f"PipelineOptions in remesh.proto ({', '.join(option_names())})")
    return spec
