#!/usr/bin/python3
"""Writes docs/api.md from the comments of the gRPC contract.

Input: a FileDescriptorSet made by `protoc --include_source_info` (scripts/gen-api-docs.sh).
Every service, method, message, field, enum and enum value is listed in declaration order with
the comment written above it in the .proto file (SourceCodeInfo). Output is deterministic: the
same .proto gives the same Markdown, byte for byte.
"""

import argparse
import sys

from google.protobuf import descriptor_pb2

# Field numbers inside descriptor.proto, used to address elements in SourceCodeInfo paths.
FILE_MESSAGE = 4
FILE_ENUM = 5
FILE_SERVICE = 6
MESSAGE_FIELD = 2
MESSAGE_NESTED = 3
MESSAGE_ENUM = 4
MESSAGE_ONEOF = 8
ENUM_VALUE = 2
SERVICE_METHOD = 2

F = descriptor_pb2.FieldDescriptorProto
SCALAR_NAMES = {
    F.TYPE_DOUBLE: "double", F.TYPE_FLOAT: "float", F.TYPE_INT64: "int64",
    F.TYPE_UINT64: "uint64", F.TYPE_INT32: "int32", F.TYPE_FIXED64: "fixed64",
    F.TYPE_FIXED32: "fixed32", F.TYPE_BOOL: "bool", F.TYPE_STRING: "string",
    F.TYPE_BYTES: "bytes", F.TYPE_UINT32: "uint32", F.TYPE_SFIXED32: "sfixed32",
    F.TYPE_SFIXED64: "sfixed64", F.TYPE_SINT32: "sint32", F.TYPE_SINT64: "sint64",
}


def clean(comment):
    """A comment as one Markdown paragraph per blank-line-separated block."""
    lines = [line.strip() for line in comment.strip("\n").split("\n")]
    blocks, current = [], []
    for line in lines:
        if not line:
            if current:
                blocks.append(current)
            current = []
        else:
            current.append(line)
    if current:
        blocks.append(current)
    out = []
    for block in blocks:
        # Keep list items on their own lines; join the rest into one paragraph.
        if any(line.startswith("- ") for line in block):
            merged = []
            for line in block:
                if line.startswith("- ") or not merged:
                    merged.append(line)
                else:
                    merged[-1] += " " + line
            out.append("\n".join(merged))
        else:
            out.append(" ".join(block))
    return "\n\n".join(out)


def cell(comment):
    """A comment on one line, for a table cell."""
    text = " ".join(line.strip() for line in comment.strip().split("\n") if line.strip())
    return text.replace("|", "\\|")


class Comments:
    def __init__(self, file_proto):
        self.by_path = {}
        for loc in file_proto.source_code_info.location:
            self.by_path[tuple(loc.path)] = loc

    def leading(self, path):
        loc = self.by_path.get(tuple(path))
        if loc is None:
            return ""
        text = loc.leading_comments
        if loc.trailing_comments:
            text = (text + "\n" + loc.trailing_comments) if text else loc.trailing_comments
        return text


def short_type(name, package):
    name = name.lstrip(".")
    if name.startswith(package + "."):
        name = name[len(package) + 1:]
    return name


def anchor(name):
    return name.lower().replace(".", "")


def type_text(field, package):
    label = "repeated " if field.label == F.LABEL_REPEATED else ""
    if field.type in (F.TYPE_MESSAGE, F.TYPE_ENUM):
        t = short_type(field.type_name, package)
        return f"{label}[`{t}`](#{anchor(t)})"
    optional = "optional " if field.proto3_optional else ""
    return f"{label}{optional}`{SCALAR_NAMES[field.type]}`"


def write_enum(out, enum, path, comments, prefix):
    name = prefix + enum.name
    out.append(f"### enum {name}\n")
    text = clean(comments.leading(path))
    if text:
        out.append(text + "\n")
    out.append("| value | number | meaning |")
    out.append("| --- | --- | --- |")
    for i, value in enumerate(enum.value):
        out.append(f"| `{value.name}` | {value.number} | "
                   f"{cell(comments.leading(path + [ENUM_VALUE, i]))} |")
    out.append("")


def write_message(out, message, path, comments, package, prefix):
    name = prefix + message.name
    if message.options.map_entry:
        return
    out.append(f"### {name}\n")
    text = clean(comments.leading(path))
    if text:
        out.append(text + "\n")
    if message.field:
        out.append("| field | number | type | meaning |")
        out.append("| --- | --- | --- | --- |")
        for i, field in enumerate(message.field):
            oneof = ""
            if field.HasField("oneof_index") and not field.proto3_optional:
                oneof = f" (oneof `{message.oneof_decl[field.oneof_index].name}`)"
            out.append(f"| `{field.name}` | {field.number} | {type_text(field, package)} | "
                       f"{cell(comments.leading(path + [MESSAGE_FIELD, i]))}{oneof} |")
        out.append("")
    else:
        out.append("No fields.\n")
    if message.reserved_range or message.reserved_name:
        ranges = [str(r.start) if r.end - r.start == 1 else f"{r.start}-{r.end - 1}"
                  for r in message.reserved_range]
        names = [f"`{n}`" for n in message.reserved_name]
        out.append("Reserved: " + ", ".join(ranges + names) + ".\n")
    for i, enum in enumerate(message.enum_type):
        write_enum(out, enum, path + [MESSAGE_ENUM, i], comments, name + ".")
    for i, nested in enumerate(message.nested_type):
        write_message(out, nested, path + [MESSAGE_NESTED, i], comments, package, name + ".")


def render(fds, source_names):
    out = [
        "# API reference: the gRPC contract",
        "",
        "<!-- Generated by scripts/gen-api-docs.sh from the comments of the .proto files; do not",
        "     edit. The ctest test deploy.api_docs_fresh fails when this file is stale. -->",
        "",
        "How the service behaves around these messages (deadlines, cache, TLS, status codes) is in",
        "[service.md](service.md); the contract's compatibility rules are checked by the contract",
        "tests against `proto/baseline/`.",
        "",
    ]
    for file_proto in fds.file:
        if file_proto.name not in source_names:
            continue
        comments = Comments(file_proto)
        package = file_proto.package
        out.append(f"## `{file_proto.name}` (package `{package}`)\n")
        # The file's leading comment is attached to the syntax statement (path [12]).
        header = clean(comments.leading([12]))
        if header:
            out.append(header + "\n")
        for si, service in enumerate(file_proto.service):
            spath = [FILE_SERVICE, si]
            out.append(f"### service {service.name}\n")
            text = clean(comments.leading(spath))
            if text:
                out.append(text + "\n")
            out.append("| method | request | response | what it does |")
            out.append("| --- | --- | --- | --- |")
            for mi, method in enumerate(service.method):
                req = short_type(method.input_type, package)
                resp = short_type(method.output_type, package)
                if method.client_streaming:
                    req = "stream " + req
                if method.server_streaming:
                    resp = "stream " + resp
                out.append(f"| `{method.name}` | [`{req}`](#{anchor(req.split()[-1])}) | "
                           f"[`{resp}`](#{anchor(resp.split()[-1])}) | "
                           f"{cell(comments.leading(spath + [SERVICE_METHOD, mi]))} |")
            out.append("")
        out.append("## Messages\n")
        for i, message in enumerate(file_proto.message_type):
            write_message(out, message, [FILE_MESSAGE, i], comments, package, "")
        if file_proto.enum_type:
            out.append("## Enums\n")
            for i, enum in enumerate(file_proto.enum_type):
                write_enum(out, enum, [FILE_ENUM, i], comments, "")
    return "\n".join(out).rstrip("\n") + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--descriptor-set", required=True,
                        help="FileDescriptorSet from protoc --include_source_info")
    parser.add_argument("--source", action="append", required=True,
                        help=".proto file name as protoc saw it (repeatable)")
    parser.add_argument("--output", required=True, help="Markdown file to write")
    args = parser.parse_args()
    fds = descriptor_pb2.FileDescriptorSet()
    with open(args.descriptor_set, "rb") as f:
        fds.ParseFromString(f.read())
    missing = [s for s in args.source if s not in {f.name for f in fds.file}]
    if missing:
        sys.exit(f"gen_api_docs: not in the descriptor set: {', '.join(missing)}")
    with open(args.output, "w", encoding="utf-8") as f:
        f.write(render(fds, set(args.source)))


if __name__ == "__main__":
    main()
