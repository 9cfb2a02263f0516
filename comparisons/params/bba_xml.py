"""The XML (XMT-style) textual form of a BBA stream, seed 000 Appendix B (preda-digest.md §3).

    <bba:BBA xmlns:bba="urn:mpeg:mpeg4:bba:schema:2002">
      <bba:header version="3.0" name=".." frameRate="10" encodingParametersFile=".."/>
      <bba:body>
        <bba:Frame>
          <bba:FrameMask KFI=".." NSBB=".." NSBM="..">
            <bba:BoneIDMask IDB=".."><bba:BoneAnimationMask isRotation="1" isRotationOnAxis1="1" .../></bba:BoneIDMask>
            <bba:MuscleIDMask IDM=".." NCP=".." NK=".." MM="0 1 ..."/>
          </bba:FrameMask>
          <bba:FrameValues>
            <bba:BoneAnimationValue RotationOnAxis1=".." .../>      (k-th value belongs to the k-th BoneIDMask)
            <bba:MuscleAnimationValue>v1 v2 ...</bba:MuscleAnimationValue>
          </bba:FrameValues>
        </bba:Frame> ...

The schema has no place for the coding parameters of the binary form; signcast writes them into
`encodingParametersFile` as
"signcast:coding=pred;q=4;intra_period=32;keyframes=0;rotation_order=0;header_period=0" so that
binary -> XML -> binary gives back the same bytes (the masks and KeyFrameIndex of every frame are
in the XML itself; values are the decoded integers; frame numbers follow from the KeyFrameIndex
values). header_period may be left out (0: no header copies).
"""
from __future__ import annotations

import xml.etree.ElementTree as ET

from comparisons.params import coding as pc
from comparisons.params.bba import MASK_FIELDS, MASK_TYPES, VALUE_LIMIT, BBAFrame, BBAHeader, BBAStream, MuscleUpdate
from media.errors import SigncastError

NAMESPACE = "urn:mpeg:mpeg4:bba:schema:2002"
_NS = "{" + NAMESPACE + "}"
PARAMETERS_PREFIX = "signcast:"


def _fps_text(fps: float) -> str:
    return str(int(fps)) if float(fps).is_integer() else repr(float(fps))


def to_xml(stream: BBAStream) -> str:
    """XML text of a BBA stream."""
    ET.register_namespace("bba", NAMESPACE)
    h = stream.header
    root = ET.Element(_NS + "BBA")
    params = (f"{PARAMETERS_PREFIX}coding={h.coding};q={h.q};intra_period={h.intra_period};"
              f"keyframes={int(h.keyframes)};rotation_order={h.rotation_order};header_period={h.header_period}")
    ET.SubElement(root, _NS + "header", version="3.0", name=h.name, frameRate=_fps_text(h.fps),
                  encodingParametersFile=params)
    body = ET.SubElement(root, _NS + "body")
    for frame in stream.frames:
        element = ET.SubElement(body, _NS + "Frame")
        mask = ET.SubElement(element, _NS + "FrameMask", KFI=str(frame.kfi), NSBB=str(len(frame.bones)),
                             NSBM=str(len(frame.muscles)))
        for bone in sorted(frame.bones):
            bone_mask = ET.SubElement(mask, _NS + "BoneIDMask", IDB=str(bone))
            attributes = {}
            for type_name, bits in MASK_TYPES:
                if any(frame.bones[bone] >> b & 1 for b in bits):
                    attributes[type_name] = "1"
                    for b in bits:
                        attributes["is" + MASK_FIELDS[b]] = str(frame.bones[bone] >> b & 1)
            ET.SubElement(bone_mask, _NS + "BoneAnimationMask", attributes)
        for muscle in frame.muscles:
            ET.SubElement(mask, _NS + "MuscleIDMask", IDM=str(muscle.muscle_id), NCP=str(muscle.n_control_points),
                          NK=str(muscle.n_knots), MM=" ".join(str(b) for b in muscle.mask))
        values = ET.SubElement(element, _NS + "FrameValues")
        for bone in sorted(frame.bones):
            bits = [b for b in range(16) if frame.bones[bone] >> b & 1]
            ET.SubElement(values, _NS + "BoneAnimationValue",
                          {MASK_FIELDS[b]: str(v) for b, v in zip(bits, frame.values[bone])})
        for muscle in frame.muscles:
            ET.SubElement(values, _NS + "MuscleAnimationValue").text = " ".join(str(v) for v in muscle.values)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n"


def _int(element: ET.Element, name: str, low: int, high: int) -> int:
    text = element.get(name)
    try:
        value = int(text)
    except (TypeError, ValueError):
        raise SigncastError(f"BBA XML: {element.tag.replace(_NS, '')} needs an integer {name}, got {text!r}") from None
    if not low <= value <= high:
        raise SigncastError(f"BBA XML: {name}={value} outside {low}..{high}")
    return value


def _parameters(text: str | None) -> dict[str, str]:
    if not text or not text.startswith(PARAMETERS_PREFIX):
        raise SigncastError("BBA XML: encodingParametersFile does not carry signcast coding parameters")
    try:
        return dict(item.split("=", 1) for item in text[len(PARAMETERS_PREFIX):].split(";"))
    except ValueError:
        raise SigncastError(f"BBA XML: bad coding parameters {text!r}") from None


def from_xml(text: str) -> BBAStream:
    """The BBA stream an XML text describes; SigncastError on malformed or inconsistent XML."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as error:
        raise SigncastError(f"BBA XML is not well-formed: {error}") from None
    if root.tag != _NS + "BBA":
        raise SigncastError("not a BBA XML document (root element bba:BBA expected)")
    header = root.find(_NS + "header")
    if header is None:
        raise SigncastError("BBA XML: the header is missing")
    params = _parameters(header.get("encodingParametersFile"))
    try:
        rate_text = header.get("frameRate", "10")
        fps = float(rate_text)
        if not fps > 0:                 # "00", "0", "-5", "nan": a stream needs a positive rate (issue 37)
            raise SigncastError(f"BBA XML: bad frameRate {rate_text[:40]!r}: a positive number of frames per second")
        pc.frame_rate_fields(fps)       # and one the binary stream can signal (SigncastError otherwise)
        stream_header = BBAHeader(header.get("name", ""), fps, params["coding"], int(params["q"]),
                                  int(params["intra_period"]), params["keyframes"] == "1", int(params["rotation_order"]),
                                  int(params.get("header_period", "0")))
    except (KeyError, ValueError) as error:
        raise SigncastError(f"BBA XML: bad header ({error})") from None
    frames = []
    body = root.find(_NS + "body")
    for element in ([] if body is None else body.findall(_NS + "Frame")):
        mask = element.find(_NS + "FrameMask")
        values = element.find(_NS + "FrameValues")
        if mask is None or values is None:
            raise SigncastError("BBA XML: a Frame needs FrameMask and FrameValues")
        kfi = _int(mask, "KFI", 0, 31)
        bone_masks = mask.findall(_NS + "BoneIDMask")
        bone_values = values.findall(_NS + "BoneAnimationValue")
        if len(bone_masks) != len(bone_values) or len(bone_masks) != _int(mask, "NSBB", 0, 1023):
            raise SigncastError("BBA XML: NSBB, BoneIDMask and BoneAnimationValue counts differ")
        bones, frame_values = {}, {}
        for bone_mask, bone_value in zip(bone_masks, bone_values):
            bone = _int(bone_mask, "IDB", 0, 1023)
            animation_mask = bone_mask.find(_NS + "BoneAnimationMask")
            bits = 0
            for type_name, type_bits in MASK_TYPES:
                if animation_mask is not None and animation_mask.get(type_name) == "1":
                    for b in type_bits:
                        bits |= int(animation_mask.get("is" + MASK_FIELDS[b], "0") == "1") << b
            names = [MASK_FIELDS[b] for b in range(16) if bits >> b & 1]
            if set(bone_value.attrib) != set(names):
                raise SigncastError(f"BBA XML: bone {bone} values {sorted(bone_value.attrib)} do not match its mask {names}")
            bones[bone] = bits
            frame_values[bone] = [_int(bone_value, name, -VALUE_LIMIT, VALUE_LIMIT) for name in names]
        muscles = []
        muscle_masks = mask.findall(_NS + "MuscleIDMask")
        muscle_values = values.findall(_NS + "MuscleAnimationValue")
        if len(muscle_masks) != len(muscle_values) or len(muscle_masks) != _int(mask, "NSBM", 0, 1023):
            raise SigncastError("BBA XML: NSBM, MuscleIDMask and MuscleAnimationValue counts differ")
        for muscle_mask, muscle_value in zip(muscle_masks, muscle_values):
            try:
                mm = [int(x) for x in (muscle_mask.get("MM") or "").split()]
                vals = [int(x) for x in (muscle_value.text or "").split()]
            except ValueError:
                raise SigncastError("BBA XML: muscle masks and values must be integers") from None
            muscles.append(MuscleUpdate(_int(muscle_mask, "IDM", 0, 1023), _int(muscle_mask, "NCP", 0, 63),
                                        _int(muscle_mask, "NK", 0, 63), mm, vals))
        frames.append(BBAFrame(kfi, bones, frame_values, muscles))
    return BBAStream(stream_header, frames)
