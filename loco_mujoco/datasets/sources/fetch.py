"""Where motion source files come from: a local copy, the user cache, or a pinned download verified by sha256.

Lookup order of :func:`source_path`: ``$LOCO_MUJOCO_SOURCES`` (or ``<repo>/../shared/mocap``), then
``$LOCO_MUJOCO_CACHE/sources`` (default ``~/.cache/loco_mujoco/sources``), then a download from the pinned URL
(or from ``$LOCO_MUJOCO_MIRROR/<relpath>``, any scheme urllib supports, e.g. ``file://``).
"""

from __future__ import annotations

import difflib
import hashlib
import os
import urllib.request
from dataclasses import dataclass
from pathlib import Path

import loco_mujoco
from loco_mujoco.atomic_write import atomic_write

_RAW = "https://raw.githubusercontent.com"
# Origins (SOURCES.md). Where the index of public repositories holds a copy of the same size at a full commit,
# that commit is noted; the shipped sha256 is checked after every download in any case.
# xbpeng/DeepMimic @ 1f915c5: full hash not found; identical-size copies at 60ebe88b27634ab697d5d3b4d80f2bfd7cd9b23a.
_DEEPMIMIC = f"{_RAW}/xbpeng/DeepMimic/1f915c5"
# opensim-org/opensim-core @ 0435b08: full hash not found (licence files fetched from it). The data files use
# the full commits where a byte-count-identical copy was found at the path given.
_OPENSIM = f"{_RAW}/opensim-org/opensim-core/0435b08"
_OPENSIM_214D202 = f"{_RAW}/opensim-org/opensim-core/214d2022c9ae3acd7d9045ff46a44c8bab12b318"
_OPENSIM_B0DDACA = f"{_RAW}/opensim-org/opensim-core/b0ddaca72a1101711517bdf304eab8b1bbd2c21b"
_OPENSIM_0A0C04D = f"{_RAW}/opensim-org/opensim-core/0a0c04dbe8badaa22686d47b23c9b1ff28be282f"
_OPENSIM_42039BE = f"{_RAW}/opensim-org/opensim-core/42039bea029b46c400204a59235d012db4af7b70"
_OPENSIM_5B8A2F6 = f"{_RAW}/opensim-org/opensim-core/5b8a2f61eee7a50cf8b67e94a969d6c188011e7a"
# robfiras/loco-mujoco @ 3a0b152 (v0.4.1): full hash not found; mini-dataset paths as stored at 83c4643 (the
# reduced_humanoid names are not in that listing: unverified).
_LOCO = f"{_RAW}/robfiras/loco-mujoco/3a0b152"
# una-dinosauria/cmu-mocap: <subject:03d>/<trial>.bvh; 09_01 and 127_07 verified by size at these commits.
_CMU_2017 = f"{_RAW}/una-dinosauria/cmu-mocap/62ac0fb0ec43cff2bf66426928f4fa6682d4bbdc"
_CMU_2018 = f"{_RAW}/una-dinosauria/cmu-mocap/f50fdd380214418ff240056a728a34adaf7bd1b0"
# Running clips added 2026-11 (SOURCES.md: "CMU clips added later"), each at the commit that holds it.
_CMU_5D98 = f"{_RAW}/una-dinosauria/cmu-mocap/5d98bb6b62b4735d89ff5f53e96899de2b92d8b4"
_CMU_34E1 = f"{_RAW}/una-dinosauria/cmu-mocap/34e1472e5b8c234d40a62bb9cd969b5910fa1803"
_CMU_E0CD = f"{_RAW}/una-dinosauria/cmu-mocap/e0cd4c298d3288de769bd4859787edc444a2ec31"
# google-research/motion_imitation @ 9263c9f: full hash not found; retarget_motion/data/ paths and sizes
# verified in the erwincoumans/motion_imitation copy.
_DOG = f"{_RAW}/google-research/motion_imitation/9263c9f"
# Escontrela/AMP_for_hardware fork WhoKnowsssss @ 3400660 (full hash found); datasets/mocap_motions/ is the
# upstream layout (unverified for this fork).
_A1 = f"{_RAW}/WhoKnowsssss/AMP_for_hardware/34006602238ae4e0757b2dcd18efb4de882b42b5"

_LICENCE_BY_FOLDER = {"deepmimic/": ("MIT", True), "opensim/": ("Apache-2.0", True),
                      "loco-mujoco-format/": ("MIT", True), "cmu/": ("CMU-free (no resale)", True),
                      "noncommercial/": ("CC-BY-NC-4.0", False)}


class SourceHashError(RuntimeError):
    """A source file's sha256 differs from the pinned manifest."""


@dataclass(frozen=True)
class SourceFile:
    """One pinned source file: download URL, sha256, licence and whether commercial use is allowed."""

    url: str
    sha256: str
    licence: str
    commercial_use: bool


# relpath (as under the shared mocap folder): (URL base at the pinned commit, path there, sha256)
_MANIFEST: dict[str, tuple[str, str, str]] = {
    "cmu/07_02.bvh": (_CMU_2017, "007/07_02.bvh",
        "c733525de3ebc2353de93afdabee85e30604447da5f68f7a552c5f0a64fe9318"),
    "cmu/08_03.bvh": (_CMU_2017, "008/08_03.bvh",
        "341df8c3b8d99976e8fe320ddc3e1cd764f55ecac3165e69df07ef0e439b5ca5"),
    "cmu/09_01.bvh": (_CMU_2017, "009/09_01.bvh",
        "90641ccca814b9d8d59f63576a548bb5612477364462d142a9f741268fbe3b78"),
    "cmu/09_04.bvh": (_CMU_2017, "009/09_04.bvh",
        "9fd8f872739053df52ecd1b26f499ee74520837062cd5bedfad2cfdfbe7cdc40"),
    "cmu/09_03.bvh": (_CMU_5D98, "data/009/09_03.bvh",
        "275d24814053eb17d6c46e00f396c4138d98c62fe5d68940447fb4ec29c4c042"),
    "cmu/09_07.bvh": (_CMU_5D98, "data/009/09_07.bvh",
        "4a4afc1d0fdd789629038421f33bb433604537e0e7bd08d0b0ec41729fdeeb99"),
    "cmu/09_08.bvh": (_CMU_34E1, "09/09_08.bvh",
        "991fe93d5aa15110434a48884847160efc6d5c859e44690322c2c6f9977a02b8"),
    "cmu/16_35.bvh": (_CMU_5D98, "data/016/16_35.bvh",
        "d20d54a9ccebd7aaf4aa6c4d7662c4905d47009401895de216a914edecf287be"),
    "cmu/35_23.bvh": (_CMU_2017, "035/35_23.bvh",
        "906db684ac4f7d980dd11e9a993d4fa2af7e303eab562e15a1b2782a0cd9afac"),
    "cmu/35_24.bvh": (_CMU_5D98, "data/035/35_24.bvh",
        "71a7811857caf22c8ae8bb700521a0b3aac350d4173185933ca7c95ad15ce081"),
    "cmu/35_25.bvh": (_CMU_E0CD, "35/35_25.bvh",
        "3434ebb52f9f65a843f1670348cbb3bdc4e9af5083c0321a93f56eb1ba4cb9c2"),
    "cmu/35_26.bvh": (_CMU_5D98, "data/035/35_26.bvh",
        "4080728a8030266c4c6844168afde02af879817efc8f747409f9aead61cc8da9"),
    "cmu/127_07.bvh": (_CMU_2018, "127/127_07.bvh",
        "96e71a06d88239571262fb8df3fda3dfb006f72ee50b57b86c8ae52b877269e2"),
    "cmu/16_36.bvh": (_CMU_2017, "016/16_36.bvh",
        "bc99c89352df21f9fed601b4529f430e364c174b6e87527144b6143e04005caf"),
    "cmu/16_45.bvh": (_CMU_2017, "016/16_45.bvh",
        "6c179f799f3b2f766ce41cf962caaae08d9342ce73fc32fbc15648bf6589e872"),
    "cmu/35_17.bvh": (_CMU_2017, "035/35_17.bvh",
        "50c6469efea1edbba0f7acd46b1fa72e0b74b78e1698aa1b441990bd2a78d730"),
    "cmu/70_02.bvh": (_CMU_2017, "070/70_02.bvh",
        "b73abe8f6b6c4bc3988a94216d7baff79731bb2a0b616f63535f43f59442b01c"),
    "cmu/70_13.bvh": (_CMU_2017, "070/70_13.bvh",
        "8599c3f7cf3493fa8a8e94315fad117cf0b23c0bf82f748da6ae404a4417be10"),
    "deepmimic/LICENSE": (_DEEPMIMIC, "LICENSE",
        "eb4aa4f4f1e9a18875e996e12a7aaf9dc078562ef5db372b55910c6599dbcdc5"),
    "deepmimic/humanoid3d.txt": (_DEEPMIMIC, "data/characters/humanoid3d.txt",
        "17469797e00704e82c53f70e3c08fd0e5adaf437b9c838b808f1173ca78c16a6"),
    "deepmimic/humanoid3d_jog.txt": (_DEEPMIMIC, "data/motions/humanoid3d_jog.txt",
        "8664855dc19871fe859b543cd27d113e6f85769cb3fe7819efb47a0341bc6fd9"),
    "deepmimic/humanoid3d_long_walk1.txt": (_DEEPMIMIC, "data/motions/long/humanoid3d_long_walk1.txt",
        "1cf7f7f2609e0fce801658598b5b04699a440aba079909dc21a30ec9d53e1a61"),
    "deepmimic/humanoid3d_long_walk2.txt": (_DEEPMIMIC, "data/motions/long/humanoid3d_long_walk2.txt",
        "82ad47ff79aece906a873b500835311ce1301a194810e15083b86e4eb5568a6b"),
    "deepmimic/humanoid3d_long_walk3.txt": (_DEEPMIMIC, "data/motions/long/humanoid3d_long_walk3.txt",
        "cab525d1eeb7b44f701fc091bdf5a4a6bfa2e77106a9d6167ba7a635a31f17d8"),
    "deepmimic/humanoid3d_run.txt": (_DEEPMIMIC, "data/motions/humanoid3d_run.txt",
        "2cbe488023b243e5769299158ce7c78875ec4b701a2ffe6c0beeaf83d16ca87b"),
    "deepmimic/humanoid3d_walk.txt": (_DEEPMIMIC, "data/motions/humanoid3d_walk.txt",
        "32d082c3599bc40aac50b1afa196ff1e2cf3842bb40f0541ab088845f6328a41"),
    "loco-mujoco-format/02-constspeed_ATLAS.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/02-constspeed_ATLAS.npz",
        "f362953caee15cc11de648240a84bc660008543132eec17dc4482b2e41ce2709"),
    "loco-mujoco-format/02-constspeed_TALOS.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/02-constspeed_TALOS.npz",
        "8f894609787b3c088548f9568a329d6de39ba2805abc8d446677aadc85e04ad4"),
    "loco-mujoco-format/02-constspeed_UnitreeG1.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/02-constspeed_UnitreeG1.npz",
        "1d94cec57a15816c0f1d6db02f1203fcb8e74bf04ca2002865d186a81aa1b6fc"),
    "loco-mujoco-format/02-constspeed_UnitreeH1.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/02-constspeed_UnitreeH1.npz",
        "85dc860dc0618685478cc7c64b2f9badbe86fdb21024e5ee2af2fa74f1bbad9a"),
    "loco-mujoco-format/02-constspeed_full_humanoid.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/02-constspeed_full_humanoid.npz",
        "82295acff0f2749ea83b4f3bb49a0ee1c13aa674ff6b00ea86d12a0d43da6461"),
    "loco-mujoco-format/02-constspeed_reduced_humanoid.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/02-constspeed_reduced_humanoid.npz",
        "8141cf685a84fe05b3288f505741f728a5dff4911626ec0f440da8057bfdf759"),
    "loco-mujoco-format/05-run_ATLAS.npz": (_LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/05-run_ATLAS.npz",
        "da3347627c84ddef0f3ce3aae55e5ed606990d2b7c9ed078382c5fca7a48884f"),
    "loco-mujoco-format/05-run_UnitreeG1.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/05-run_UnitreeG1.npz",
        "5df800b94cbadb15fce0969f95248a557774145dfa5c92d7a71e8386d3a559b3"),
    "loco-mujoco-format/05-run_UnitreeH1.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/05-run_UnitreeH1.npz",
        "758982999d6bb542b4575626509369b8995cd467100007bb236f92d621a36a13"),
    "loco-mujoco-format/05-run_full_humanoid.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/05-run_full_humanoid.npz",
        "b3a88a9fa06aad04c5dd4553bef0a21292503d42165054d2fecc93a4b8f43b62"),
    "loco-mujoco-format/05-run_reduced_humanoid.npz": (
        _LOCO, "loco_mujoco/datasets/humanoids/real/mini_datasets/05-run_reduced_humanoid.npz",
        "fc356a7bdb80a08167ff5d0b584c860f660cfe2ef199817ec3104d6c53ba12f2"),
    "loco-mujoco-format/LICENSE": (_LOCO, "LICENSE",
        "24ccd46f2e1650c25c60459f835fd2e21ff928c8b4282b4aa4eb697b03b104bf"),
    "loco-mujoco-format/walk_straight.npz": (
        _LOCO, "loco_mujoco/datasets/quadrupeds/real/mini_datasets/walk_straight.npz",
        "e631a248c45bbc182392147ad38b0c62ab8eac81fc212605ccdf04b7a1a421db"),
    "noncommercial/a1-retargeted/LICENSE.txt": (_A1, "datasets/mocap_motions/LICENSE.txt",
        "8784f6f1cb8488fc8e2e8af2556e24578df6ccf22d5060dbe640d9f98a6fb28e"),
    "noncommercial/a1-retargeted/canter0.txt": (_A1, "datasets/mocap_motions/canter0.txt",
        "5b320fd1f76796f33dd18c582824829e91603548516f654df340a462c05783c4"),
    "noncommercial/a1-retargeted/canter1.txt": (_A1, "datasets/mocap_motions/canter1.txt",
        "ffae5d517ed1b9948f5e21425f81db40ee2e5359cb6a67bf74481fd3e9ad117f"),
    "noncommercial/a1-retargeted/canter2.txt": (_A1, "datasets/mocap_motions/canter2.txt",
        "db80f56364769164eab5f5be5264df6908e43eef61a15bda18abd49070de171c"),
    "noncommercial/a1-retargeted/left_turn0.txt": (_A1, "datasets/mocap_motions/left_turn0.txt",
        "ac01ea019ba20d543c92c37a45fa54b185c8058860ed9230b2ed629d75ae5016"),
    "noncommercial/a1-retargeted/left_turn1.txt": (_A1, "datasets/mocap_motions/left_turn1.txt",
        "b4ee65ec35e58a105a4362e4ae6bbbd41d9df7b02900eea170e95aa0f9c088fe"),
    "noncommercial/a1-retargeted/pace0.txt": (_A1, "datasets/mocap_motions/pace0.txt",
        "75152085945a9d319eac997c6b21f0362167baa743cf33886e82349a51d6da51"),
    "noncommercial/a1-retargeted/pace1.txt": (_A1, "datasets/mocap_motions/pace1.txt",
        "f4e9cb2d792f6ca941edeb185a62216842558e2d4acffe482366da9fbe571c31"),
    "noncommercial/a1-retargeted/pace2.txt": (_A1, "datasets/mocap_motions/pace2.txt",
        "8d2c198625d8f5c89ea50f19f48c857f50e40b93cddb7b97b6a5ef41752dd40e"),
    "noncommercial/a1-retargeted/right_turn0.txt": (_A1, "datasets/mocap_motions/right_turn0.txt",
        "38cbe180cd670816739e7cde123d697b97f7cd86eda3719b3dbf7b4826cda5a6"),
    "noncommercial/a1-retargeted/right_turn1.txt": (_A1, "datasets/mocap_motions/right_turn1.txt",
        "a83ccc5e7e575e3a15c0802b5c208ca1527bd5bf986c9b7b544cfd7dd92ec12c"),
    "noncommercial/a1-retargeted/trot0.txt": (_A1, "datasets/mocap_motions/trot0.txt",
        "f0300fca1e6c8571ca776ee21cf4fe8016256148910de8304a885d0590c6519e"),
    "noncommercial/a1-retargeted/trot1.txt": (_A1, "datasets/mocap_motions/trot1.txt",
        "34dafe20530748e3b407d4314a9c9d861759aa7e4872327ee0e95481fa5640a0"),
    "noncommercial/a1-retargeted/trot2.txt": (_A1, "datasets/mocap_motions/trot2.txt",
        "897b8a7286e7575ba592605bb9c4ee7c2393e8a3859d4e0d14ce5f8870c27d30"),
    "noncommercial/deepmimic-sie-runs/LICENSE": (_DEEPMIMIC, "data/motions/sie/LICENSE",
        "64d8a680a19e604c853597c8c1182bd720851b6876f79e22139db883f3047bca"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_forward00.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_forward00.txt",
        "ab83f6d673b0536b60f86fa74efb2d2fc19c1d00bc8eb8b07c5c07fa872068d7"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_forward02.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_forward02.txt",
        "d7d6d4b0817aa0eb01248d38576e09fec577d04a1dbdc9ac5e2f5358b8f379f4"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_forward04.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_forward04.txt",
        "cbaa60d3a6fc288d1944114d1e117ded0e57b1e0345df8b4456abeb937b5559c"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_forward06.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_forward06.txt",
        "008196cad8be1510aa80b6df6649ab8479450fd98fcd4dc702fd3955898ad256"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_forward08.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_forward08.txt",
        "c2bc6ed0dc14f41b8a22e67403a9421598ebfe498ec29096d2b9be38c294415d"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_forward10.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_forward10.txt",
        "871ae49d4f97383f214d32c010820027558d2c08fdabe4da14205fe91f0d5806"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_forward12.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_forward12.txt",
        "96b27bd95319e6abb898abec052de12a080d5d0c55af6e524b420b8451fcd0ff"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_forward14.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_forward14.txt",
        "dd452876e677219fe9a3342dcab06e1305062d9803a1e7ee4a9353d79c559cc4"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left00.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left00.txt",
        "d74bf2c06fdecf5e293272af661582a2eb2adf9ffbf7ca0d7b5592ab33e52515"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left01.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left01.txt",
        "cf87a0a15c75a437d1f962338ca6087ea3308d6d6ea4bea3b929b7c1bae3d20f"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left02.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left02.txt",
        "08ad15ba9121eb6f1a9f2efba92d507470459f01dba59f7e0f611b9191b385dc"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left03.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left03.txt",
        "2dbc3e05c1af5a7ec0e1a2664cdcd6824610bead88a8978c13651359fe8eb514"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left04.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left04.txt",
        "014a7307ead3750eac7faa14079389cf35eeaaa600231f02efdf43fd9008071c"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left05.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left05.txt",
        "0b273c9c72cc9469aede18894463f2a96e8dd66f64790d365048b816cab3140b"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left06.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left06.txt",
        "a6f18c7df87861352f634488c2fb219016113ff47e8baa2a2ce232a52f833c7e"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left07.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left07.txt",
        "65df7c08880d18632b0abd5eca8fb9db80c9ae004cc931646ed19976e0855062"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left08.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left08.txt",
        "2a377038bbd6f94c51730ae774353c3f270e13728a76b2f45ecebf51b7f4944d"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left09.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left09.txt",
        "aa14527712c477a58f5f5b13483fd8eabeec220b6efc5c2549db9954a2360ee6"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left10.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left10.txt",
        "4631b7e25df28d855cfab30feee5b80d61106bc73dd3d4be71c6593a31b9a6df"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left11.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left11.txt",
        "ffb7b15368079e90c256840b57961f20718493914ea81bc44318ad1686628bdd"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left12.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left12.txt",
        "735bcb7c6e8df600e8034f3003b54b4f99fe65ad3ffb45a04545bffa91d7aab4"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left13.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left13.txt",
        "f0367199cddcc6a5aae5a7622cc912813406ec1c3e0421f60a40567e8ca7670b"),
    "noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_left14.txt": (
        _DEEPMIMIC, "data/motions/sie/sie_humanoid3d_run_left14.txt",
        "3f48bd4ceec06a2d90f03cfdc838ce3b8f0aece6be7fe03f0ca83d69971ea459"),
    "noncommercial/dog-keypoints/LICENSE.txt": (_DOG, "retarget_motion/data/LICENSE.txt",
        "8784f6f1cb8488fc8e2e8af2556e24578df6ccf22d5060dbe640d9f98a6fb28e"),
    "noncommercial/dog-keypoints/dog_clips_info.txt": (_DOG, "retarget_motion/data/dog_clips_info.txt",
        "4f4cd1f5e7e128df629c33a43ae614413bd18875da9ed818c25a4d65fe71954f"),
    "noncommercial/dog-keypoints/dog_pace_joint_pos.txt": (_DOG, "retarget_motion/data/dog_pace_joint_pos.txt",
        "e56c9b0c90873038f1fa22f447013f09fddd2c768742f873d09852af74010224"),
    "noncommercial/dog-keypoints/dog_run00_joint_pos.txt": (_DOG, "retarget_motion/data/dog_run00_joint_pos.txt",
        "2a0d09de7d19fd3929dc84dc7ffe195d9c55c46465b8fd15ec2332b120461d96"),
    "noncommercial/dog-keypoints/dog_run01_joint_pos.txt": (_DOG, "retarget_motion/data/dog_run01_joint_pos.txt",
        "96dda820005f42588fbd174f3df2a7c4024b4fd5e12992dcc553e18be2b57909"),
    "noncommercial/dog-keypoints/dog_run02_joint_pos.txt": (_DOG, "retarget_motion/data/dog_run02_joint_pos.txt",
        "92bc170194909f9adfdbe17d3f8e1974ba4af3bf0536de692ae7b375f7da0688"),
    "noncommercial/dog-keypoints/dog_run04_joint_pos.txt": (_DOG, "retarget_motion/data/dog_run04_joint_pos.txt",
        "8006b5f67532a5aa8fcadcba0d971bbc798b0c3aaf86fd4254ae2e33fcef3e40"),
    "noncommercial/dog-keypoints/dog_trot_joint_pos.txt": (_DOG, "retarget_motion/data/dog_trot_joint_pos.txt",
        "6bc27204d248457cec64104969e6d8c6b93cadcfb7d2d391b45748860b3d9745"),
    "noncommercial/dog-keypoints/dog_turn00_joint_pos.txt": (_DOG, "retarget_motion/data/dog_turn00_joint_pos.txt",
        "91b071b0085f00af3507a3e44559018818e6b5ecdfb83e6e161f32cfef83f25b"),
    "noncommercial/dog-keypoints/dog_walk00_joint_pos.txt": (_DOG, "retarget_motion/data/dog_walk00_joint_pos.txt",
        "1fdedeb3419a545a5090c200edf8d0076ccfe723ecc0eacfe4fa24a0849736dc"),
    "noncommercial/dog-keypoints/dog_walk01_joint_pos.txt": (_DOG, "retarget_motion/data/dog_walk01_joint_pos.txt",
        "7b6db5537cbc99b7e2064428354318ea9d6725b92c5e11839b38c8acfdcc2625"),
    "noncommercial/dog-keypoints/dog_walk02_joint_pos.txt": (_DOG, "retarget_motion/data/dog_walk02_joint_pos.txt",
        "8f0a50053f49d5e385837c136672235f5bf34f21bfedcfd448db360af2cb0eff"),
    "noncommercial/dog-keypoints/dog_walk03_joint_pos.txt": (_DOG, "retarget_motion/data/dog_walk03_joint_pos.txt",
        "c5db797262ae63a131a8a956a75b2697ff7c3b318ebbc0e18f02ad05d2743a3f"),
    "noncommercial/dog-keypoints/dog_walk04_joint_pos.txt": (_DOG, "retarget_motion/data/dog_walk04_joint_pos.txt",
        "5ac2b0b6bff919deb86b98b5d800d89a6630c76ef6da0d0e71f292283f30d829"),
    "noncommercial/dog-keypoints/dog_walk05_joint_pos.txt": (_DOG, "retarget_motion/data/dog_walk05_joint_pos.txt",
        "a7ec09efe7b3cf59351d981b0f076d9d17baecc8375dd28a6fa327e00813721a"),
    "noncommercial/dog-keypoints/dog_walk06_joint_pos.txt": (_DOG, "retarget_motion/data/dog_walk06_joint_pos.txt",
        "19d22e885ab20adf8b3c538bc1f53065458fc54432437309c68b7ab5c4315c0b"),
    "noncommercial/dog-keypoints/dog_walk09_joint_pos.txt": (_DOG, "retarget_motion/data/dog_walk09_joint_pos.txt",
        "8a75d08a3e4ac879c0d9ad8e39a8867d481af4e6c89ab66fa22e60a2174e35d3"),
    "opensim/LICENSE.txt": (_OPENSIM, "LICENSE.txt",
        "cfc7749b96f63bd31c3c42b5c471bf756814053e847c10f3eb003417bc523d30"),
    "opensim/NOTICE": (_OPENSIM, "NOTICE",
        "b2c1b5cb94d4cb080aa2e589cb03863f27fa7ed4bc2b6c6dfb42a46f0d38c2cd"),
    "opensim/subject01_walk1_ik.mot": (_OPENSIM_214D202, "Applications/ID/test/subject01_walk1_ik.mot",
        "752a125afddfa442c76fe74807b66b3d8e3836cac3a15cd409283766bcf402d4"),
    "opensim/subject02_running_arms_ik.mot": (
        _OPENSIM_B0DDACA, "Applications/Analyze/tests/resources/subject02_running_arms_ik.mot",
        "198b5b1633cc094eabe60c9064c630644f206b3c72f9793bde6f64cb7332a206"),
    "opensim/walk_free_01.trc": (
        _OPENSIM_0A0C04D, "Bindings/Java/Matlab/testData/Subject01/MarkerData/walk_free_01.trc",
        "139f575152c96c225efb9d2ea3d2fcb8f3df70cf621d4c472508cad0d2d7fc27"),
    "opensim/walk_free_02.trc": (
        _OPENSIM_42039BE, "Bindings/Java/Matlab/examples/testData/Subject01/MarkerData/walk_free_02.trc",
        "de76e9668100ef950550a82fc7b34dc6cef798add987e943292999a251462272"),
    "opensim/walk_free_03.trc": (
        _OPENSIM_5B8A2F6, "Bindings/Java/Matlab/examples/testData/Subject01/MarkerData/walk_free_03.trc",
        "6018ac526515b88e844a80747d6e63050efd94603303fe9121a69e49f279b557"),}


def _entry(relpath: str, base: str, path: str, sha: str) -> SourceFile:
    licence, commercial = next(v for k, v in _LICENCE_BY_FOLDER.items() if relpath.startswith(k))
    return SourceFile(url=f"{base}/{path}", sha256=sha, licence=licence, commercial_use=commercial)


SOURCE_FILES: dict[str, SourceFile] = {rel: _entry(rel, *spec) for rel, spec in _MANIFEST.items()}


def default_sources_root() -> Path | None:
    """``$LOCO_MUJOCO_SOURCES`` (must exist), else ``<repo root>/../shared/mocap`` if present, else None."""
    env = os.environ.get("LOCO_MUJOCO_SOURCES")
    if env:
        root = Path(env).expanduser()
        if not root.is_dir():
            raise FileNotFoundError(f"LOCO_MUJOCO_SOURCES={env!r} is not an existing folder")
        return root
    shared = Path(loco_mujoco.__file__).resolve().parents[1].parent / "shared" / "mocap"
    return shared if shared.is_dir() else None


class CacheDirError(OSError):
    """The cache folder cannot be created or written; the message names it and the variable that chose it."""


def cache_dir() -> Path:
    """Root of the download cache: ``$LOCO_MUJOCO_CACHE`` or ``~/.cache/loco_mujoco``, created if missing.

    A folder that cannot be created or written raises :class:`CacheDirError` naming the variable."""
    value = os.environ.get("LOCO_MUJOCO_CACHE")
    path = Path(value or Path.home() / ".cache" / "loco_mujoco").expanduser()
    where = f"LOCO_MUJOCO_CACHE={value!r}" if value else f"the default cache folder {path}"
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise CacheDirError(f"{where} is not usable: cannot create {path} ({err.strerror or err}); "
                            "point LOCO_MUJOCO_CACHE at a writable folder") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise CacheDirError(f"{where} is not usable: {path} is not writable; point LOCO_MUJOCO_CACHE at a "
                            "writable folder")
    return path


def sha256_of(path: str | Path) -> str:
    """Hex sha256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _lookup(relpath: str) -> SourceFile:
    if relpath not in SOURCE_FILES:
        close = difflib.get_close_matches(relpath, list(SOURCE_FILES), n=3, cutoff=0.5)
        raise KeyError(f"unknown source file {relpath!r}" + (f"; did you mean {close}?" if close else ""))
    return SOURCE_FILES[relpath]


def _check(path: Path, relpath: str, expected: str) -> None:
    _require_hash(sha256_of(path), relpath, path, expected)


def _require_hash(actual: str, relpath: str, where: Path | str, expected: str) -> None:
    """Raise ``SourceHashError`` naming the file, where its bytes came from, and both hashes, unless they match."""
    if actual != expected:
        raise SourceHashError(f"{relpath} ({where}): sha256 {actual} does not match the pinned {expected}")


def _download(relpath: str, entry: SourceFile, target: Path) -> None:
    """Stream ``entry`` into ``target`` through an atomic write, hashing as it arrives; a mismatch leaves nothing."""
    mirror = os.environ.get("LOCO_MUJOCO_MIRROR")
    url = f"{mirror.rstrip('/')}/{relpath}" if mirror else entry.url
    digest = hashlib.sha256()
    with atomic_write(target, "wb") as out:
        try:
            with urllib.request.urlopen(url, timeout=60) as response:
                while chunk := response.read(1 << 20):
                    digest.update(chunk)
                    out.write(chunk)
        except OSError as err:
            raise OSError(f"cannot download {relpath} from {url}: {err}") from err
        # raised inside the write: the temporary is removed, the target untouched
        _require_hash(digest.hexdigest(), relpath, url, entry.sha256)


def source_path(relpath: str, allow_download: bool = True, verify: bool = False) -> Path:
    """Local path of a pinned source file (local root, then cache, then a verified download)."""
    entry = _lookup(relpath)
    root = default_sources_root()
    if root is not None and (root / relpath).is_file():
        if verify:
            _check(root / relpath, relpath, entry.sha256)
        return root / relpath
    cached = cache_dir() / "sources" / relpath
    if cached.is_file():
        if verify:
            try:
                _check(cached, relpath, entry.sha256)
            except SourceHashError:
                cached.unlink()
                raise
        return cached
    if not allow_download:
        raise FileNotFoundError(
            f"source file {relpath!r} is not available offline: no copy under the local sources root ({root}) "
            f"nor in the cache ({cached}). Set LOCO_MUJOCO_SOURCES to a folder holding the motion sources "
            f"(laid out as the shared mocap folder) or call with allow_download=True to fetch it from {entry.url} "
            f"(or from $LOCO_MUJOCO_MIRROR).")
    _download(relpath, entry, cached)
    return cached
