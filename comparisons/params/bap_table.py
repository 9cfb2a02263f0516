"""The MPEG-4 BAP set: 296 body animation parameters (ids 1..296), their joints, axes, groups and steps.

Sources (restated in ../shared/notes/mpeg4-facts.md §1, which cites each fact):
- ids 1..186 standard, 187..296 extension BAPs (`extensionBap187`..): GPAC `include/gpac/nodes_mpeg4.h`
  (BIFS BAP node, 296 fields), visage `FBACodecCommon.h` (NBAP 186, NUM_BAPS 296), VREng `bap.hpp`
  (.bap versions 3.1 = 186 and 3.2 = 296 values).
- names: GPAC field names (vertebrae written without underscore, `vc1roll`; BAP 20/21 `*_midtarsal_flexion`).
- joint and parent joint (H-Anim 1.1 names): Greta `JointType.java`.
- axis: Greta's X/Y/Z column (`JointType.java`); visage `BAPs.h` signed axis code kept as `visage_axis`.
- group (1..24) and the order BAPs are coded in inside a group: visage `FBAEncoder.cpp`
  (`bap_mask_index`, `baps_in_group`); group labels are descriptive (official names not found).
- quantisation step (BQP): visage `FBACodecCommon.h` "standard" table (cross-checked against the
  visage|toolkit manual: vc6_torsion 256, vt1_roll 128); the "experiment" table is kept as `step_visage_exp`.
- units: rotations in 1e-5 rad (Greta `BAP.java` radianFactor 100000; seed 004 "Body Animation
  Parameters"); translations (181..183) in mm (seed 004).

Values chosen here because no readable source gives them:
- `step` of the three root translations: the "standard" table gives 64, which in mm would be a
  64 mm step; signcast uses the visage "experiment" value 2 (mm).
- `range`: the standard per-BAP min/max table (14496-2 Amd.1 Annex C) was not readable; rotations
  use (-pi, pi] = +-314159 units (the BBA schema's bound, seed 000 App. B), translations +-100000 mm.
- extension BAPs: step 1 in both visage tables would code 1e-5 rad steps; signcast uses them for
  avatar rotations the standard set lacks (see comparisons/params/fba_mapping.py) and gives them step 128.
"""
from __future__ import annotations

from dataclasses import dataclass

N_BAPS = 296
N_STANDARD_BAPS = 186
N_GROUPS = 24
ROTATION_UNIT_RAD = 1e-5
TRANSLATION_UNIT_M = 1e-3
ROTATION_RANGE = 314159
TRANSLATION_RANGE = 100000
TRANSLATION_BAPS = (181, 182, 183)
EXTENSION_STEP = 128


@dataclass(frozen=True)
class Bap:
    """One BAP: id 1..296, name, joint (H-Anim), parent joint, axis ('X', 'Y', 'Z' rotation or
    'T' translation, '-' for extension BAPs), visage axis code, group 1..24, quantisation step
    (BAP units), range (min, max in BAP units)."""
    id: int
    name: str
    joint: str
    parent: str
    axis: str
    visage_axis: int
    group: int
    step: int
    step_visage_exp: int
    range: tuple[int, int]

    @property
    def is_translation(self) -> bool:
        return self.id in TRANSLATION_BAPS


_STANDARD = [
    (1, "sacroiliac_tilt", "sacroiliac", "HumanoidRoot", "X", -1, 1, 64, 170),
    (2, "sacroiliac_torsion", "sacroiliac", "HumanoidRoot", "Y", 2, 1, 64, 170),
    (3, "sacroiliac_roll", "sacroiliac", "HumanoidRoot", "Z", 3, 1, 64, 170),
    (4, "l_hip_flexion", "l_hip", "sacroiliac", "X", -1, 2, 128, 170),
    (5, "r_hip_flexion", "r_hip", "sacroiliac", "X", -1, 3, 128, 170),
    (6, "l_hip_abduct", "l_hip", "sacroiliac", "Z", 3, 2, 128, 170),
    (7, "r_hip_abduct", "r_hip", "sacroiliac", "Z", 3, 3, 128, 170),
    (8, "l_hip_twisting", "l_hip", "sacroiliac", "Y", -2, 4, 256, 256),
    (9, "r_hip_twisting", "r_hip", "sacroiliac", "Y", -2, 5, 256, 256),
    (10, "l_knee_flexion", "l_knee", "l_hip", "X", -1, 2, 128, 170),
    (11, "r_knee_flexion", "r_knee", "r_hip", "X", -1, 3, 128, 170),
    (12, "l_knee_twisting", "l_knee", "l_hip", "Y", -2, 4, 256, 256),
    (13, "r_knee_twisting", "r_knee", "r_hip", "Y", -2, 5, 256, 256),
    (14, "l_ankle_flexion", "l_ankle", "l_knee", "X", -1, 2, 128, 170),
    (15, "r_ankle_flexion", "r_ankle", "r_knee", "X", -1, 3, 128, 170),
    (16, "l_ankle_twisting", "l_ankle", "l_knee", "Y", -2, 4, 256, 256),
    (17, "r_ankle_twisting", "r_ankle", "r_knee", "Y", -2, 5, 256, 256),
    (18, "l_subtalar_flexion", "l_subtalar", "l_ankle", "Z", 3, 4, 256, 256),
    (19, "r_subtalar_flexion", "r_subtalar", "r_ankle", "Z", 3, 5, 256, 256),
    (20, "l_midtarsal_flexion", "l_midtarsal", "l_subtalar", "Z", 3, 4, 256, 256),
    (21, "r_midtarsal_flexion", "r_midtarsal", "r_subtalar", "Z", 3, 5, 256, 256),
    (22, "l_metatarsal_flexion", "l_metatarsal", "l_midtarsal", "X", -1, 4, 256, 256),
    (23, "r_metatarsal_flexion", "r_metatarsal", "r_midtarsal", "X", -1, 5, 256, 256),
    (24, "l_sternoclavicular_abduct", "l_sternoclavicular", "vt1", "Z", 3, 8, 128, 170),
    (25, "r_sternoclavicular_abduct", "r_sternoclavicular", "vt1", "Z", 3, 9, 128, 170),
    (26, "l_sternoclavicular_rotate", "l_sternoclavicular", "vt1", "Y", 2, 8, 128, 170),
    (27, "r_sternoclavicular_rotate", "r_sternoclavicular", "vt1", "Y", 2, 9, 128, 170),
    (28, "l_acromioclavicular_abduct", "l_acromioclavicular", "l_sternoclavicular", "Z", 3, 8, 128, 170),
    (29, "r_acromioclavicular_abduct", "r_acromioclavicular", "r_sternoclavicular", "Z", 3, 9, 128, 170),
    (30, "l_acromioclavicular_rotate", "l_acromioclavicular", "l_sternoclavicular", "Y", 2, 8, 128, 170),
    (31, "r_acromioclavicular_rotate", "r_acromioclavicular", "r_sternoclavicular", "Y", 2, 9, 128, 170),
    (32, "l_shoulder_flexion", "l_shoulder", "l_acromioclavicular", "X", -1, 6, 64, 170),
    (33, "r_shoulder_flexion", "r_shoulder", "r_acromioclavicular", "X", -1, 7, 64, 170),
    (34, "l_shoulder_abduct", "l_shoulder", "l_acromioclavicular", "Z", 3, 6, 64, 170),
    (35, "r_shoulder_abduct", "r_shoulder", "r_acromioclavicular", "Z", 3, 7, 64, 170),
    (36, "l_shoulder_twisting", "l_shoulder", "l_acromioclavicular", "Y", -2, 6, 256, 256),
    (37, "r_shoulder_twisting", "r_shoulder", "r_acromioclavicular", "Y", -2, 7, 256, 256),
    (38, "l_elbow_flexion", "l_elbow", "l_shoulder", "X", -1, 6, 64, 170),
    (39, "r_elbow_flexion", "r_elbow", "r_shoulder", "X", -1, 7, 64, 170),
    (40, "l_elbow_twisting", "l_elbow", "l_shoulder", "Y", -2, 8, 256, 256),
    (41, "r_elbow_twisting", "r_elbow", "r_shoulder", "Y", -2, 9, 256, 256),
    (42, "l_wrist_flexion", "l_wrist", "l_elbow", "Z", -3, 6, 128, 170),
    (43, "r_wrist_flexion", "r_wrist", "r_elbow", "Z", -3, 7, 128, 170),
    (44, "l_wrist_pivot", "l_wrist", "l_elbow", "X", -1, 8, 128, 170),
    (45, "r_wrist_pivot", "r_wrist", "r_elbow", "X", -1, 9, 128, 170),
    (46, "l_wrist_twisting", "l_wrist", "l_elbow", "Y", -2, 8, 256, 256),
    (47, "r_wrist_twisting", "r_wrist", "r_elbow", "Y", -2, 9, 256, 256),
    (48, "skullbase_roll", "skullbase", "vc1", "Z", 3, 10, 128, 170),
    (49, "skullbase_torsion", "skullbase", "vc1", "Y", 2, 10, 128, 170),
    (50, "skullbase_tilt", "skullbase", "vc1", "X", -1, 10, 128, 170),
    (51, "vc1roll", "vc1", "vc2", "Z", 3, 14, 256, 256),
    (52, "vc1torsion", "vc1", "vc2", "Y", 2, 14, 256, 256),
    (53, "vc1tilt", "vc1", "vc2", "X", -1, 14, 256, 256),
    (54, "vc2roll", "vc2", "vc3", "Z", 3, 11, 128, 170),
    (55, "vc2torsion", "vc2", "vc3", "Y", 2, 11, 128, 170),
    (56, "vc2tilt", "vc2", "vc3", "X", -1, 11, 128, 170),
    (57, "vc3roll", "vc3", "vc4", "Z", 3, 12, 256, 256),
    (58, "vc3torsion", "vc3", "vc4", "Y", 2, 12, 256, 256),
    (59, "vc3tilt", "vc3", "vc4", "X", -1, 12, 256, 256),
    (60, "vc4roll", "vc4", "vc5", "Z", 3, 10, 128, 170),
    (61, "vc4torsion", "vc4", "vc5", "Y", 2, 10, 128, 170),
    (62, "vc4tilt", "vc4", "vc5", "X", -1, 10, 128, 170),
    (63, "vc5roll", "vc5", "vc6", "Z", 3, 13, 256, 256),
    (64, "vc5torsion", "vc5", "vc6", "Y", 2, 13, 256, 256),
    (65, "vc5tilt", "vc5", "vc6", "X", -1, 13, 256, 256),
    (66, "vc6roll", "vc6", "vc7", "Z", 3, 12, 256, 256),
    (67, "vc6torsion", "vc6", "vc7", "Y", 2, 12, 256, 256),
    (68, "vc6tilt", "vc6", "vc7", "X", -1, 12, 256, 256),
    (69, "vc7roll", "vc7", "vt1", "Z", 3, 13, 256, 256),
    (70, "vc7torsion", "vc7", "vt1", "Y", 2, 13, 256, 256),
    (71, "vc7tilt", "vc7", "vt1", "X", -1, 13, 256, 256),
    (72, "vt1roll", "vt1", "vt2", "Z", 3, 11, 128, 170),
    (73, "vt1torsion", "vt1", "vt2", "Y", 2, 11, 128, 170),
    (74, "vt1tilt", "vt1", "vt2", "X", -1, 11, 128, 170),
    (75, "vt2roll", "vt2", "vt3", "Z", 3, 13, 256, 256),
    (76, "vt2torsion", "vt2", "vt3", "Y", 2, 13, 256, 256),
    (77, "vt2tilt", "vt2", "vt3", "X", -1, 13, 256, 256),
    (78, "vt3roll", "vt3", "vt4", "Z", 3, 14, 256, 256),
    (79, "vt3torsion", "vt3", "vt4", "Y", 2, 14, 256, 256),
    (80, "vt3tilt", "vt3", "vt4", "X", -1, 14, 256, 256),
    (81, "vt4roll", "vt4", "vt5", "Z", 3, 12, 256, 256),
    (82, "vt4torsion", "vt4", "vt5", "Y", 2, 12, 256, 256),
    (83, "vt4tilt", "vt4", "vt5", "X", -1, 12, 256, 256),
    (84, "vt5roll", "vt5", "vt6", "Z", 3, 14, 256, 256),
    (85, "vt5torsion", "vt5", "vt6", "Y", 2, 14, 256, 256),
    (86, "vt5tilt", "vt5", "vt6", "X", -1, 14, 256, 256),
    (87, "vt6roll", "vt6", "vt7", "Z", 3, 10, 128, 170),
    (88, "vt6torsion", "vt6", "vt7", "Y", 2, 10, 128, 170),
    (89, "vt6tilt", "vt6", "vt7", "X", -1, 10, 128, 170),
    (90, "vt7roll", "vt7", "vt8", "Z", 3, 13, 256, 256),
    (91, "vt7torsion", "vt7", "vt8", "Y", 2, 13, 256, 256),
    (92, "vt7tilt", "vt7", "vt8", "X", -1, 13, 256, 256),
    (93, "vt8roll", "vt8", "vt9", "Z", 3, 12, 256, 256),
    (94, "vt8torsion", "vt8", "vt9", "Y", 2, 12, 256, 256),
    (95, "vt8tilt", "vt8", "vt9", "X", -1, 12, 256, 256),
    (96, "vt9roll", "vt9", "vt10", "Z", 3, 14, 256, 256),
    (97, "vt9torsion", "vt9", "vt10", "Y", 2, 14, 256, 256),
    (98, "vt9tilt", "vt9", "vt10", "X", -1, 14, 256, 256),
    (99, "vt10roll", "vt10", "vt11", "Z", 3, 11, 128, 170),
    (100, "vt10torsion", "vt10", "vt11", "Y", 2, 11, 128, 170),
    (101, "vt10tilt", "vt10", "vt11", "X", -1, 11, 128, 170),
    (102, "vt11roll", "vt11", "vt12", "Z", 3, 13, 256, 256),
    (103, "vt11torsion", "vt11", "vt12", "Y", 2, 13, 256, 256),
    (104, "vt11tilt", "vt11", "vt12", "X", -1, 13, 256, 256),
    (105, "vt12roll", "vt12", "vl1", "Z", 3, 12, 256, 256),
    (106, "vt12torsion", "vt12", "vl1", "Y", 2, 12, 256, 256),
    (107, "vt12tilt", "vt12", "vl1", "X", -1, 12, 256, 256),
    (108, "vl1roll", "vl1", "vl2", "Z", 3, 11, 128, 170),
    (109, "vl1torsion", "vl1", "vl2", "Y", 2, 11, 128, 170),
    (110, "vl1tilt", "vl1", "vl2", "X", -1, 11, 128, 170),
    (111, "vl2roll", "vl2", "vl3", "Z", 3, 13, 256, 256),
    (112, "vl2torsion", "vl2", "vl3", "Y", 2, 13, 256, 256),
    (113, "vl2tilt", "vl2", "vl3", "X", -1, 13, 256, 256),
    (114, "vl3roll", "vl3", "vl4", "Z", 3, 10, 128, 170),
    (115, "vl3torsion", "vl3", "vl4", "Y", 2, 10, 128, 170),
    (116, "vl3tilt", "vl3", "vl4", "X", -1, 10, 128, 170),
    (117, "vl4roll", "vl4", "vl5", "Z", 3, 12, 256, 256),
    (118, "vl4torsion", "vl4", "vl5", "Y", 2, 12, 256, 256),
    (119, "vl4tilt", "vl4", "vl5", "X", -1, 12, 256, 256),
    (120, "vl5roll", "vl5", "HumanoidRoot", "Z", 3, 11, 128, 170),
    (121, "vl5torsion", "vl5", "HumanoidRoot", "Y", 2, 11, 128, 170),
    (122, "vl5tilt", "vl5", "HumanoidRoot", "X", -1, 11, 128, 170),
    (123, "l_pinky0_flexion", "l_pinky0", "l_wrist", "Z", -1, 17, 512, 512),
    (124, "r_pinky0_flexion", "r_pinky0", "r_wrist", "Z", -1, 18, 512, 512),
    (125, "l_pinky1_flexion", "l_pinky1", "l_pinky0", "Z", -1, 15, 128, 170),
    (126, "r_pinky1_flexion", "r_pinky1", "r_pinky0", "Z", -1, 16, 128, 170),
    (127, "l_pinky1_pivot", "l_pinky1", "l_pinky0", "X", 3, 17, 128, 170),
    (128, "r_pinky1_pivot", "r_pinky1", "r_pinky0", "X", 3, 18, 128, 170),
    (129, "l_pinky1_twisting", "l_pinky1", "l_pinky0", "Y", -2, 17, 256, 256),
    (130, "r_pinky1_twisting", "r_pinky1", "r_pinky0", "Y", -2, 18, 256, 256),
    (131, "l_pinky2_flexion", "l_pinky2", "l_pinky1", "Z", -1, 15, 128, 170),
    (132, "r_pinky2_flexion", "r_pinky2", "r_pinky1", "Z", -1, 16, 128, 170),
    (133, "l_pinky3_flexion", "l_pinky3", "l_pinky2", "Z", -1, 15, 128, 170),
    (134, "r_pinky3_flexion", "r_pinky3", "r_pinky2", "Z", -1, 16, 128, 170),
    (135, "l_ring0_flexion", "l_ring0", "l_wrist", "Z", -1, 17, 256, 256),
    (136, "r_ring0_flexion", "r_ring0", "r_wrist", "Z", -1, 18, 256, 256),
    (137, "l_ring1_flexion", "l_ring1", "l_ring0", "Z", -1, 15, 128, 170),
    (138, "r_ring1_flexion", "r_ring1", "r_ring0", "Z", -1, 16, 128, 170),
    (139, "l_ring1_pivot", "l_ring1", "l_ring0", "X", 3, 17, 128, 170),
    (140, "r_ring1_pivot", "r_ring1", "r_ring0", "X", 3, 18, 128, 170),
    (141, "l_ring1_twisting", "l_ring1", "l_ring0", "Y", -2, 17, 256, 256),
    (142, "r_ring1_twisting", "r_ring1", "r_ring0", "Y", -2, 18, 256, 256),
    (143, "l_ring2_flexion", "l_ring2", "l_ring1", "Z", -1, 15, 128, 170),
    (144, "r_ring2_flexion", "r_ring2", "r_ring1", "Z", -1, 16, 128, 170),
    (145, "l_ring3_flexion", "l_ring3", "l_ring2", "Z", -1, 15, 128, 170),
    (146, "r_ring3_flexion", "r_ring3", "r_ring2", "Z", -1, 16, 128, 170),
    (147, "l_middle0_flexion", "l_middle0", "l_wrist", "Z", -1, 17, 256, 256),
    (148, "r_middle0_flexion", "r_middle0", "r_wrist", "Z", -1, 18, 256, 256),
    (149, "l_middle1_flexion", "l_middle1", "l_middle0", "Z", -1, 15, 128, 170),
    (150, "r_middle1_flexion", "r_middle1", "r_middle0", "Z", -1, 16, 128, 170),
    (151, "l_middle1_pivot", "l_middle1", "l_middle0", "X", 3, 17, 128, 170),
    (152, "r_middle1_pivot", "r_middle1", "r_middle0", "X", 3, 18, 128, 170),
    (153, "l_middle1_twisting", "l_middle1", "l_middle0", "Y", -2, 17, 256, 256),
    (154, "r_middle1_twisting", "r_middle1", "r_middle0", "Y", -2, 18, 256, 256),
    (155, "l_middle2_flexion", "l_middle2", "l_middle1", "Z", -1, 15, 128, 170),
    (156, "r_middle2_flexion", "r_middle2", "r_middle1", "Z", -1, 16, 128, 170),
    (157, "l_middle3_flexion", "l_middle3", "l_middle2", "Z", -1, 15, 128, 170),
    (158, "r_middle3_flexion", "r_middle3", "r_middle2", "Z", -1, 16, 128, 170),
    (159, "l_index0_flexion", "l_index0", "l_wrist", "Z", -1, 17, 256, 256),
    (160, "r_index0_flexion", "r_index0", "r_wrist", "Z", -1, 18, 256, 256),
    (161, "l_index1_flexion", "l_index1", "l_index0", "Z", -1, 15, 128, 170),
    (162, "r_index1_flexion", "r_index1", "r_index0", "Z", -1, 16, 128, 170),
    (163, "l_index1_pivot", "l_index1", "l_index0", "X", 3, 17, 128, 170),
    (164, "r_index1_pivot", "r_index1", "r_index0", "X", 3, 18, 128, 170),
    (165, "l_index1_twisting", "l_index1", "l_index0", "Y", -2, 17, 256, 256),
    (166, "r_index1_twisting", "r_index1", "r_index0", "Y", -2, 18, 256, 256),
    (167, "l_index2_flexion", "l_index2", "l_index1", "Z", -1, 15, 128, 170),
    (168, "r_index2_flexion", "r_index2", "r_index1", "Z", -1, 16, 128, 170),
    (169, "l_index3_flexion", "l_index3", "l_index2", "Z", -1, 15, 128, 170),
    (170, "r_index3_flexion", "r_index3", "r_index2", "Z", -1, 16, 128, 170),
    (171, "l_thumb1_flexion", "l_thumb1", "l_wrist", "X", -1, 15, 128, 170),
    (172, "r_thumb1_flexion", "r_thumb1", "r_wrist", "X", -1, 16, 128, 170),
    (173, "l_thumb1_pivot", "l_thumb1", "l_wrist", "Y", 3, 15, 128, 170),
    (174, "r_thumb1_pivot", "r_thumb1", "r_wrist", "Y", 3, 16, 128, 170),
    (175, "l_thumb1_twisting", "l_thumb1", "l_wrist", "Z", -2, 17, 256, 256),
    (176, "r_thumb1_twisting", "r_thumb1", "r_wrist", "Z", -2, 18, 256, 256),
    (177, "l_thumb2_flexion", "l_thumb2", "l_thumb1", "X", -1, 15, 128, 170),
    (178, "r_thumb2_flexion", "r_thumb2", "r_thumb1", "X", -1, 16, 128, 170),
    (179, "l_thumb3_flexion", "l_thumb3", "l_thumb2", "X", -1, 15, 128, 170),
    (180, "r_thumb3_flexion", "r_thumb3", "r_thumb2", "X", -1, 16, 128, 170),
    (181, "HumanoidRoot_tr_vertical", "HumanoidRoot", "-", "transl.", 5, 19, 64, 2),
    (182, "HumanoidRoot_tr_lateral", "HumanoidRoot", "-", "transl.", 4, 19, 64, 2),
    (183, "HumanoidRoot_tr_frontal", "HumanoidRoot", "-", "transl.", 6, 19, 64, 2),
    (184, "HumanoidRoot_rt_body_turn", "HumanoidRoot", "-", "Y", 2, 19, 64, 170),
    (185, "HumanoidRoot_rt_body_roll", "HumanoidRoot", "-", "Z", 3, 19, 64, 170),
    (186, "HumanoidRoot_rt_body_tilt", "HumanoidRoot", "-", "X", 1, 19, 64, 170),
]

GROUP_LABELS = (
    "pelvis", "left leg 1", "right leg 1", "left leg 2", "right leg 2", "left arm 1", "right arm 1",
    "left arm 2", "right arm 2", "spine 1", "spine 2", "spine 3", "spine 4", "spine 5",
    "left hand 1", "right hand 1", "left hand 2", "right hand 2", "global positioning",
    "extension 1", "extension 2", "extension 3", "extension 4", "extension 5",
)

# BAP ids of each group in coding order (visage FBAEncoder.cpp bap_mask_index / baps_in_group).
GROUP_MEMBERS: tuple[tuple[int, ...], ...] = (
    (1, 2, 3),
    (4, 6, 10, 14),
    (5, 7, 11, 15),
    (8, 12, 16, 18, 20, 22),
    (9, 13, 17, 19, 21, 23),
    (32, 34, 36, 38, 42),
    (33, 35, 37, 39, 43),
    (24, 26, 28, 30, 40, 44, 46),
    (25, 27, 29, 31, 41, 45, 47),
    (48, 49, 50, 60, 61, 62, 87, 88, 89, 114, 115, 116),
    (54, 55, 56, 72, 73, 74, 99, 100, 101, 108, 109, 110, 120, 121, 122),
    (57, 58, 59, 66, 67, 68, 81, 82, 83, 93, 94, 95, 105, 106, 107, 117, 118, 119),
    (63, 64, 65, 69, 70, 71, 75, 76, 77, 90, 91, 92, 102, 103, 104, 111, 112, 113),
    (51, 52, 53, 78, 79, 80, 84, 85, 86, 96, 97, 98),
    (125, 131, 133, 137, 143, 145, 149, 155, 157, 161, 167, 169, 171, 173, 177, 179),
    (126, 132, 134, 138, 144, 146, 150, 156, 158, 162, 168, 170, 172, 174, 178, 180),
    (123, 127, 129, 135, 139, 141, 147, 151, 153, 159, 163, 165, 175),
    (124, 128, 130, 136, 140, 142, 148, 152, 154, 160, 164, 166, 176),
    (181, 182, 183, 184, 185, 186),
    tuple(range(187, 209)), tuple(range(209, 231)), tuple(range(231, 253)),
    tuple(range(253, 275)), tuple(range(275, 297)),
)


def _build() -> tuple[Bap, ...]:
    baps = []
    for (i, name, joint, parent, axis, visage_axis, group, step, step_exp) in _STANDARD:
        translation = i in TRANSLATION_BAPS
        baps.append(Bap(i, name, joint, parent, "T" if translation else axis, visage_axis, group,
                        2 if translation else step, step_exp,
                        (-TRANSLATION_RANGE, TRANSLATION_RANGE) if translation else (-ROTATION_RANGE, ROTATION_RANGE)))
    for i in range(N_STANDARD_BAPS + 1, N_BAPS + 1):
        group = 20 + (i - N_STANDARD_BAPS - 1) // 22
        baps.append(Bap(i, f"extensionBap{i}", "-", "-", "-", 0, group, EXTENSION_STEP, 1,
                        (-ROTATION_RANGE, ROTATION_RANGE)))
    return tuple(baps)


BAPS: tuple[Bap, ...] = _build()
BY_NAME = {bap.name: bap for bap in BAPS}


def bap(bap_id: int) -> Bap:
    """The BAP with 1-based id `bap_id`."""
    return BAPS[bap_id - 1]


def steps():
    """(296,) int64 quantisation step of every BAP (index = id - 1), BAP units."""
    import numpy as np
    return np.array([b.step for b in BAPS], dtype=np.int64)


def _check() -> None:
    members = sorted(i for group in GROUP_MEMBERS for i in group)
    assert members == list(range(1, N_BAPS + 1)), "BAP groups must partition ids 1..296"
    for g, group in enumerate(GROUP_MEMBERS, start=1):
        assert all(BAPS[i - 1].group == g for i in group), f"group {g} disagrees with the table"


_check()
