"""Byte identity of every parameter codec's streams and decoded values against stored references.

The references (SHA-256 of the encoded bytes and of the decoded array's bytes) were taken with the
pure-Python coders before their hot loops were compiled; a faster coder must reproduce them exactly.
Inputs are stored arrays, not live retargeting (which keeps changing):

- tests/data/fba_bap_clips.npz: BAP values (T, 296) int32 of ASL "HELLO" (25 fps, 84 frames) and
  "J" (10 fps, 10 frames), shared with tests/test_fap_coding.py;
- tests/data/param_codec_clips.npz: for "ase_HELLO_25fps" (80 frames) and "ase_J_10fps" (10 frames),
  the avatar Motion as the BBA codec receives it (rotations (T, 105, 4) float64 quaternions with the
  face bones of synthetic FAPs on HELLO, root_translation (T, 3) metres, bone_names, fps) and the
  seed-002 signing DOFs (T, 183) radians; and "faps/<BAP clip>" FAP values (T, 68) int32 for the
  BAP clips (comparisons.params.fap_rates.synthetic_faps).

The seed-002 coders also read their shipped tables (comparisons/tables): retraining them changes
their streams, and these references must then be re-recorded with the reference coder (the
pure-Python comparisons/params/entropy.py and bitstream.py before Numba). The fixtures were written from
media.fingerspelling (fingerspell "HELLO", letter_motion "J") with the retargeting of 2 Dec 2026.
"""
import hashlib
from pathlib import Path

import numpy as np
import pytest

from comparisons.params import bba as bba_codec
from comparisons.params.fba import decode_fba, encode_fba
from comparisons.lab.codecs import LAB_CODEC_NAMES, LabCodec
from media.motion import Motion

DATA = Path(__file__).resolve().parent / "data"
BAP_FPS = {"ase_HELLO_25fps": 25.0, "ase_J_10fps": 10.0}
MOTIONS = ("ase_HELLO_25fps", "ase_J_10fps")


def _sha(array_or_bytes) -> str:
    if isinstance(array_or_bytes, np.ndarray):
        array_or_bytes = np.ascontiguousarray(array_or_bytes).tobytes()
    return hashlib.sha256(array_or_bytes).hexdigest()


def _load():
    with np.load(DATA / "fba_bap_clips.npz") as clips, np.load(DATA / "param_codec_clips.npz") as stored:
        baps = {name: clips[name].astype(np.int64) for name in BAP_FPS}
        faps = {name: stored[f"faps/{name}"].astype(np.int64) for name in BAP_FPS}
        motions = {key: Motion(float(stored[f"{key}/fps"]), [str(n) for n in stored[f"{key}/bone_names"]],
                               stored[f"{key}/rotations"], stored[f"{key}/root_translation"]) for key in MOTIONS}
        dofs = {key: stored[f"{key}/dofs"] for key in MOTIONS}
    return baps, faps, motions, dofs


BAPS, FAPS, MOTION_CLIPS, DOFS = _load()


def fba_digests(clip: str, coding: str, q: int, with_faps: bool) -> tuple[str, str]:
    data = encode_fba(BAPS[clip], BAP_FPS[clip], q, coding, faps=FAPS[clip] if with_faps else None)
    decoded = decode_fba(data)
    arrays = decoded.baps if not with_faps else np.concatenate([decoded.baps, decoded.faps], axis=1)
    return _sha(data), _sha(arrays)


BBA_CODECS = {"bba-pred": ("pred", False), "bba-dct": ("dct", False), "bba-key": ("pred", True)}


def bba_digests(clip: str, codec: str, q: int) -> tuple[str, str]:
    coding, keyframes = BBA_CODECS[codec]
    data = bba_codec.write_stream(bba_codec.motion_to_stream(MOTION_CLIPS[clip], q, coding, keyframes=keyframes))
    decoded = bba_codec.stream_to_motion(bba_codec.read_stream(data)[0])
    return _sha(data), _sha(np.concatenate([decoded.rotations.reshape(len(decoded.rotations), -1),
                                            decoded.root_translation], axis=1))


def lab_digests(clip: str, name: str, q: int) -> tuple[str, str]:
    codec = LabCodec(name)
    data, _ = codec.encode_dofs(DOFS[clip], MOTION_CLIPS[clip].fps, codec.index_of(q))
    decoded, fps = codec.decode_dofs(data)
    assert fps == MOTION_CLIPS[clip].fps
    return _sha(data), _sha(decoded)


# operating points hashed before finer ones were added (wavelet k = 8..10): they stay checked
EARLIER_QS = {"wavelet": {4, 8}}


def lab_qs(name: str) -> tuple[int, ...]:
    n = len(LabCodec(name).settings())
    return tuple(sorted({1, (n + 1) // 2, n} | EARLIER_QS.get(name, set())))


def all_cases():
    """(kind, arguments) of every stored reference."""
    for clip in BAP_FPS:
        for coding in ("pred", "dct"):
            for with_faps in (False, True):
                for q in (1, 8, 31):
                    yield "fba", (clip, coding, q, with_faps)
    for clip in MOTIONS:
        for codec in BBA_CODECS:
            for q in (1, 8, 31):
                yield "bba", (clip, codec, q)
    for clip in MOTIONS:
        for name in LAB_CODEC_NAMES:
            for q in lab_qs(name):
                yield "lab", (clip, name, q)


DIGESTS = {"fba": fba_digests, "bba": bba_digests, "lab": lab_digests}
# (kind, arguments): (SHA-256 of the stream, SHA-256 of the decoded array), recorded before the speed-up
REFERENCE = {
    ('fba', ('ase_HELLO_25fps', 'pred', 1, False)): ('641a65aea79e3065a7690ceb58d25c2cec3bfb24901131d5b52873dfd3535558',
        '0d95a872adc9e9050f7f93637b7291d67a5d49b98d66deccae36b56516c18cce'),
    ('fba', ('ase_HELLO_25fps', 'pred', 8, False)): ('8e2d5d51d1497196a232345597ba3f4aab507ecbeae90c2931dfcc96d01c4196',
        '363dedd5c31c174134f61e45e7dddc36da5e1ef5778490d6141ab29c07992b85'),
    ('fba', ('ase_HELLO_25fps', 'pred', 31, False)): ('00001e0f23af3ae8a38a823f10b6862cdaf5edc4ef5cb5a058d6ced68e6a02f4',
        '14000dd999ee56feabeec79a48ed3ea3c1e3d882c9db89a2b8895406ee0c6f90'),
    ('fba', ('ase_HELLO_25fps', 'pred', 1, True)): ('e8954e02619161e1b3a296493d5bd7ab5f1f842e3879e4cca03a3860a8737d1d',
        'a9ad7a7242951ae1af205f33513dfaa037a155bdd5d5dc0df7dee0e795b798a8'),
    ('fba', ('ase_HELLO_25fps', 'pred', 8, True)): ('790b1f8489fe57090cb6576567b1dec69bb7aa3d5da4db6dec66c35a1bf743d5',
        'fcbb62e70841b1480373f2d74655d48abd2866d0e46a036e43e16e17645746f2'),
    ('fba', ('ase_HELLO_25fps', 'pred', 31, True)): ('87cfd00c32e7818c9a1552c586e087add63a6d4305a4b4c0bf3c185185d421e5',
        '687afcb6a26d24c8b9d07ed822a8d7f45fe5d7bd13d92f16d8956cfb5ebc309b'),
    ('fba', ('ase_HELLO_25fps', 'dct', 1, False)): ('02d11055afc764633463a9b20541b28849515b69b0c6cb24fcd44fb03a0999ac',
        '3491598957c7138cebe72e3d411f0e22627e2183d3804ad923b074e046267a1f'),
    ('fba', ('ase_HELLO_25fps', 'dct', 8, False)): ('04d6b3a1992595f4bd8b0b9141dfdf2629981ee53e57c03315186773f0cb7d3c',
        '16ecace3fbab3e6c7b90b69547ccd5b42452ba2be0118573695909fae2158ad7'),
    ('fba', ('ase_HELLO_25fps', 'dct', 31, False)): ('787fde53046c98c98383f8545170b1ff5a160fa87f622a2f38c12eadd133156f',
        '1d37718fef8f5aba6dbfb10de3fb1854d3ee8f01345589d170a5266469179b9d'),
    ('fba', ('ase_HELLO_25fps', 'dct', 1, True)): ('5af66e9a9c0c1dd2aba48e04634e77d409f34ee08e37d04dcb104c2e263f6228',
        '1e07481b2ee4b0c7f87a51f7587acebb6a24cd28338a88058f3d2ae6abb6f94c'),
    ('fba', ('ase_HELLO_25fps', 'dct', 8, True)): ('3f22d39d070a8368d53bd12b1574c160881a0f1bf47a0b9bd7ec61f96d997e10',
        '8f5c06d4b3fe78d501258bd974c631468a6ba118a90c8c5c4edc007c515d736e'),
    ('fba', ('ase_HELLO_25fps', 'dct', 31, True)): ('3cc981fa88c3377bd48a33383318b95f7e94b1fc670fb14ddf60106e055cce5a',
        '52ed0d8fa1dc1e9c0bf9e36f9916f53063432d5a51baac6383526cc3c0e234ea'),
    ('fba', ('ase_J_10fps', 'pred', 1, False)): ('789622fa1312af3d794ac0cdd77f742410832861dd21852471b916f89bd609c5',
        '00a0faebc1f020f641863dc6014216b5afddad59e0b5e3ede87bebfe490c6e5d'),
    ('fba', ('ase_J_10fps', 'pred', 8, False)): ('c651611b7de53c7572c8d0aaeaf6ad297a3155fee0cb3c8d939490646ac05d84',
        'cbffe7362ffea179bfa91849f71175083b2d8cd7e9f4f318af898bba3c728449'),
    ('fba', ('ase_J_10fps', 'pred', 31, False)): ('ab6d091193763035dd0f613da3136f1252eb93b2dc390df93ae8a9ee9ac41f48',
        'b667a76a63e0df767483a1d8167885bd3e92f659d019bddb08004480e63dcee0'),
    ('fba', ('ase_J_10fps', 'pred', 1, True)): ('b7c7a0fb399d4083009dd273a530299149022904fc57641ec60fa52bb63baad5',
        '9e46838c9a9970a2f9b6973f722c3d9ee1d606874b6f84d0e5b3a72eff6bb526'),
    ('fba', ('ase_J_10fps', 'pred', 8, True)): ('ab7ae8d2c1e4d3f6a9e4f94fe5129dedac595860d3fe28ee8ccc13817011c7db',
        '5fd4c1aae7ba242468760cac09be62a463f751a5f94312b6e02d7e5f979c6685'),
    ('fba', ('ase_J_10fps', 'pred', 31, True)): ('158243aeed8b01bedef8a578fac0e9b6f44d7ce5f8f82e2410297baa4107d8bf',
        'ddb3bb7704001cadac7546e018d9f229d4d8b5ae04ec854b79824780288a9343'),
    ('fba', ('ase_J_10fps', 'dct', 1, False)): ('d55be203cbc7083041b86b0ce071cf004241145d49e1014be79dbb86f08c2010',
        '2bfa3d4d0685c428bed1074aacf71fc34eb9fa2e5fb961d2c9ba5679d383809c'),
    ('fba', ('ase_J_10fps', 'dct', 8, False)): ('e399d0bb53177074216db11e796a17aa557198832d9a1050b2407c7170e93f01',
        '903277c78ce399da230cf76fdd396c7af366a491ae5e8408c3aab6f3793e6126'),
    ('fba', ('ase_J_10fps', 'dct', 31, False)): ('966e7befaf95211e87a742a23b29938a7cb1e1994b80641b6c1a21b0475c49ad',
        'f10549b6dfeaf33ac403726417a34fe5de188dab7fb120135666d69da86eddbf'),
    ('fba', ('ase_J_10fps', 'dct', 1, True)): ('b1de525b76b34206fe582f807bd211b0007b0b4dadb1fe1a1f7b6898c6441bf0',
        '931b888964386c46827910517a561054854da45419f36bbb22fe3ea592bbc13f'),
    ('fba', ('ase_J_10fps', 'dct', 8, True)): ('ff5087bc61661104e774df224b7daf64abe6fea17ddbabddc2ba9014a4ae44ce',
        'fcfdd307034e980686be923fdc7af108d3425cd24e2e6204310a302af090865c'),
    ('fba', ('ase_J_10fps', 'dct', 31, True)): ('dd08b9149d10f5b9076ebbfe7236aacfd2bfd1e35d4ddc319d377eb10e1f1b2c',
        '846702bf377287a1c7136de1d56fd5261186d07b16f58a323a1175f2b86cece1'),
    ('bba', ('ase_HELLO_25fps', 'bba-pred', 1)): ('cc23fa27a2e7c31cc79f97513b53bafde891e2ce6d7b7918cc09e1f3f9e3f1bd',
        'b38e03924ea998589fff03b245257261603f3398b07a2cee0a78059d790e143d'),
    ('bba', ('ase_HELLO_25fps', 'bba-pred', 8)): ('0cb40ee8649cf9f44e171c64aa9e209f785b505abcdd2cfc2282304ed8ff2cfc',
        'faf092d82798757696132e3fda56fa6935a57a47c329ee31f39262f56a97571c'),
    ('bba', ('ase_HELLO_25fps', 'bba-pred', 31)): ('696c7c1d2f49bdf11d4b7efe1147de05edbe1037027a7f5ad96c82311e9b48ea',
        'd73a539b068fa01d04abea79122003188494247136f892b4dd348e9f6d6dce0d'),
    ('bba', ('ase_HELLO_25fps', 'bba-dct', 1)): ('483b6b129e2f3d42cb896d89249b47c35290f720cccffae52bf9eb39aae7883e',
        '929167ecf1aef67281f15d1ad18dafe5a8e134f160634907ee2c6591828e0b2b'),
    ('bba', ('ase_HELLO_25fps', 'bba-dct', 8)): ('11d37508dc464980f3e3b6aa9c0ae1041fc4a22a83dafefa4c4d8054f123a313',
        '79c6b7cdb05d9018f25a7784f454d03641d17e1c294dba73dd40c54027513c5e'),
    ('bba', ('ase_HELLO_25fps', 'bba-dct', 31)): ('14374cb867a497f439267162b04fb34341d39d9e65c834305e6a20428d5d5b92',
        'bc0bc3451d7052b2a9863a0c04f5d7adbc0168ee49a3b276d75c57b46be2210c'),
    ('bba', ('ase_HELLO_25fps', 'bba-key', 1)): ('b970fe7fa9e1e4469961991184b48f773400db3a947302476ba49f1c945c70e9',
        'cd188f38340993f7db9003b31ccd579509f12ffac347788d74a5b7b953ee6800'),
    ('bba', ('ase_HELLO_25fps', 'bba-key', 8)): ('51e8d40152a4696fdb0870ea20f55e28ab89d1f156edbb80a9c201952f84e624',
        'cc89095588a1298a61b21eade2646efbf784c05c08948cd5a9a51a0a198c4761'),
    ('bba', ('ase_HELLO_25fps', 'bba-key', 31)): ('23ec5fe746d8449d0d49a8cb2f714f46c55287e4b3e0a2f90a983060f4eea1a6',
        '8b4bb0b7d7ec34abf7d4182165af6f9a913f6c85ba5c8ef1e61e4e9e1b9ad0e5'),
    ('bba', ('ase_J_10fps', 'bba-pred', 1)): ('3cfab435123531705f3a8ce5534918bcb29909f1c813b68fe1a899adc4bb5f84',
        '0ea0f20b98a2337abf62f48ad86aec146e927822f07f223e7409d385ca223953'),
    ('bba', ('ase_J_10fps', 'bba-pred', 8)): ('73f8ac1c5b2ec6640c2e429dbd196b852cbd1ee46648cbdff5ce56b9b7a44e11',
        'e951599ae66ebca5fa46e67ad039cb723a5b81a4dd9a04e7aee728492819a6f1'),
    ('bba', ('ase_J_10fps', 'bba-pred', 31)): ('9413f4ab7a14f6d371ec78baa2ae260aa38cae62c4582fdd0caf48eb632db80f',
        '1a532218f807f2d92c4048ce67b94f2ace24052ff45596ae82fd1fae0c4ace4c'),
    ('bba', ('ase_J_10fps', 'bba-dct', 1)): ('82fd996884139376bb08ff4c2cdbae7dea2f29ad81d98e5dc6907fa51603a095',
        '76c0851b1cbd4619b0a499ce7daef225ed064c4308dda2b9dd3db97a53af0863'),
    ('bba', ('ase_J_10fps', 'bba-dct', 8)): ('133cc12d3dead94d565d53b1154d95758452526350b351d5acfa6a278e7c81ac',
        '53cd890fb598e0184d37c655aa71a8124ad300723feaef9a84ce95e66297ffb7'),
    ('bba', ('ase_J_10fps', 'bba-dct', 31)): ('49fca5dd6cf52266c7c136d0f1798d235552d83d301c8dc03db99c38313aef05',
        'f4be6885778a36287fa2a55583be7252b56007a4ccd2f18e8dbb5ec399da76be'),
    ('bba', ('ase_J_10fps', 'bba-key', 1)): ('92132ff681ba802b5637b00f78b2c9c73055895e76f942c54bfbd93d221f19de',
        '0ea0f20b98a2337abf62f48ad86aec146e927822f07f223e7409d385ca223953'),
    ('bba', ('ase_J_10fps', 'bba-key', 8)): ('2058158ea35bc644084ffe2adc4603ffa1fcb14397ea3fa7d02bb6f0192615a0',
        'e951599ae66ebca5fa46e67ad039cb723a5b81a4dd9a04e7aee728492819a6f1'),
    ('bba', ('ase_J_10fps', 'bba-key', 31)): ('2c69e34f6b03f09b6a17f88cab3930839cd5d9abd3b0098ccde0de62a3c5231a',
        '1a532218f807f2d92c4048ce67b94f2ace24052ff45596ae82fd1fae0c4ace4c'),
    ('lab', ('ase_HELLO_25fps', 'quant', 1)): ('6ac627ce637118661b7b895c29659cc5d8a7e19d9466349119da8cba1ddedd18',
        '236af7ff8fefd8e025f2679c67a7c269dd8376dbb90b5da238b91c5e99de7aa7'),
    ('lab', ('ase_HELLO_25fps', 'quant', 3)): ('0de97d03fe21ac300c46962bb8ef3c8a4b08d4d6abb0b48ba13a8cb2fb423b1b',
        'b7ac4b02b1a2e9c148a0753f38c123724de3e5bf3149625f8fc461153e86dfbf'),
    ('lab', ('ase_HELLO_25fps', 'quant', 6)): ('f3efea7d54a46f902a9c6e1ceaccf0a9475392d613179b3a462ab596e31d51b4',
        '72fef10063ffcc0e095e23ffc1a4748f005538036d3bec26cb2db2af3713d83d'),
    ('lab', ('ase_HELLO_25fps', 'nuquant', 1)): ('8b9d732c4ef2d72b9e5000d490c2c3c713073208e91d3f274e5ed1d86103d27d',
        'bc60641a76acbda546fa92b1c1cca4d43db1d5d66d5fd9a5a1ef3ffded4c99c1'),
    ('lab', ('ase_HELLO_25fps', 'nuquant', 3)): ('d801fbd295df5dfe4d629737d735fda6a24ee4e7d385050711727340e2652685',
        '1636eea6f66bca55d52a0e7d6052e30fc69e687d864d60c9b1a0ac7d0843c186'),
    ('lab', ('ase_HELLO_25fps', 'nuquant', 6)): ('fd467bfe0a6a8fec2194e132795965ba1bc39847f0f609a7ec52fe1c746e29bb',
        'ddc7575eee402b66c44892c3cc7e6732effc9bef1c0d80c2fc80cc6a9902b22c'),
    ('lab', ('ase_HELLO_25fps', 'dpcm', 1)): ('c65daca90c42c229ade43a961dcb39b5ed681ee79f7617f70a42d2cd964913d1',
        '2b3b75da394a4e2e360eec538fbbbbb76b3937b61eedad96dd4c9bb112a977ab'),
    ('lab', ('ase_HELLO_25fps', 'dpcm', 4)): ('1394cf8671d3161e7ba856718f6aeed4c2e0bc288b0da4607fbebb9f1858d35a',
        '0fdce3b079af2e769de251920fb99287ec2a0ec475962af8726010cf1bfaa033'),
    ('lab', ('ase_HELLO_25fps', 'dpcm', 7)): ('0ab116efe2ef138ecedec921110724e89eb29403a3ec96c9177176407177d4c6',
        'ab32047df3f77a5a8b3c216a2364fb8b07dbfe8a6180548ecf929165dcdb4b6f'),
    ('lab', ('ase_HELLO_25fps', 'adpcm', 1)): ('a87e9614cb3fbf40a11721029ffa13c67463dd8eeae6304ae361c548c8221346',
        'b322e696102b5222f1b35f5e8f4904858c90b589e4aba1d8ed1f12acb2d16eab'),
    ('lab', ('ase_HELLO_25fps', 'adpcm', 4)): ('4cfafa9609ba6ff36fa82bc50856b9db565e260c618d1c26c56533a5a5cba6ac',
        '19b1b7ecffcb222a8f45556584608c8e20bd6a0864441dfb84dcc0debc30d971'),
    ('lab', ('ase_HELLO_25fps', 'adpcm', 7)): ('6f324e4ed44dddd257afdf9f0076567101bfc6a3d38fb02d13e1b467ae97a5b2',
        'dbf80b49957c27404968618e06f37bb8516f37a88b70dd55074c8912ab10cdc8'),
    ('lab', ('ase_HELLO_25fps', 'deadreck', 1)): ('f5ecaef8baf6fa4f92af88f95e317220f92fb0efa857fe05b907a05c059f0344',
        '5dacc752310fcfde84194b6e8864d77da7fa3d27eaa693f94bc3e53beceef6f3'),
    ('lab', ('ase_HELLO_25fps', 'deadreck', 4)): ('9bbcfb0aa4d6580f4954ca38f33533de40d8c5acfd5fbb5654581ab7f2a1dfbe',
        '98089e6b5664b0a7d07f67c678e93a97d932f8281639af732bce3c812fc882fa'),
    ('lab', ('ase_HELLO_25fps', 'deadreck', 8)): ('787078ec1e38c9befaf49bc8eb6ed5409febe5b9862f3d92b428a78ec414a6f6',
        'e01226e83750fc3bf5693cdf25cb18eb9b72fea29f94b577664e4be71952c210'),
    ('lab', ('ase_HELLO_25fps', 'dct', 1)): ('802e258d4de3faa97c7f1a8e8d5f391785ef60a1a87942324094e6d40986d274',
        'b6039b7109ba009c4d2fb04c9789762646a8c1cb3f3a9f5b8f4c8d23db919ede'),
    ('lab', ('ase_HELLO_25fps', 'dct', 3)): ('41cf77ebed79f4186062f759a3fe8d3153354eafa9df338d8fa8cc7e7e70988b',
        '7a917b4dc98e865ce9e09b2e9dea0ab08a6cf09ee0d635e2ee95624ad4386b29'),
    ('lab', ('ase_HELLO_25fps', 'dct', 6)): ('955212ceccb2568a2e403bed816b87c2a8fecfa2eab630c752a5e7536c8a22b7',
        '377df8f48419f0aecfd6677c30289b46e7ebe189662fd51698bc189c0f911e4e'),
    ('lab', ('ase_HELLO_25fps', 'wavelet', 1)): ('3bae4ff6428454b5ea3d1aea9a4e00468778eb0e7897dfe0ecf9f3427c67cc3f',
        'a3f30ff05e52e061c8113e26415097408e79fe7d0b3022629211bd5f1f216970'),
    ('lab', ('ase_HELLO_25fps', 'wavelet', 4)): ('26113238ceb33c92e62e7b3a20046a6c442a33fe689fe2961b8f3e876be7dd3d',
        '8d2aac65aa71ae587d80b55a76198e5fc1de3cdb76d10eb5e170765f868dfaec'),
    ('lab', ('ase_HELLO_25fps', 'wavelet', 8)): ('019bd33c35623582b582205ee57f63f8fc82ebba78c7ab85bd78c4f5522b92f4',
        '4f27ad633dba68dea9d5cf2ba2b1d3f566eee490e4d98c187f6dd76b7b7c4ce3'),
    ('lab', ('ase_HELLO_25fps', 'wavelet', 11)): ('6eec0b0d6e0fa2070f1a606746a9a712895593e5a182e681623c7e9da46b7801',
        '8c1236b15300a249fa39d55d2e1e5e5754396ca3253d6826a2c3515b4538713a'),
    ('lab', ('ase_HELLO_25fps', 'wavelet', 6)): ('971dcddb84ac0bd81e1dc32f15231e6a9547ad425d9f2d302d469f339b889f62',
        'fa0e8945e3bdb7973342d4902c0a6e1bb6e17bc6a55ba81792365e7f27fa0b85'),
    ('lab', ('ase_HELLO_25fps', 'svq', 1)): ('6025c845f8a2b1b4aeeb1ed2fb43475713f57b8fd68bb0311134da500b6c29d4',
        'e11178fc4d3fa9e93371e3d74abac2ce5373c8ddf25cd785026be42897567cc4'),
    ('lab', ('ase_HELLO_25fps', 'svq', 3)): ('a8ca4cbeb84a5bd840f3d48b5d3ae3bf9f62a3d3b4858be6ebb8f66e39986ddd',
        '5137af1feeacf6a050df035e6cf522f53a14f685388d4e00b7b6e19fe88ef2dc'),
    ('lab', ('ase_HELLO_25fps', 'svq', 6)): ('5a3944f950257f5257669459b8d6dcab45c16061acc4dd140ee02a3bebfd2039',
        '5a17f72eb936e4e25f1a86d5f2041ef4a13235c698531aceaf487dbe2975cd53'),
    ('lab', ('ase_HELLO_25fps', 'tvq', 1)): ('1657c528c32cfbdcdada6f7d413bac99d663b6133a437783c973d625069c386a',
        '6b655c93219cd5b87f295a6aa5f85f53d287dc474868a75e3d54ab6fa89dd38d'),
    ('lab', ('ase_HELLO_25fps', 'tvq', 3)): ('a8fda50c8595aa39aa741852f8bb7a67b3eaa7b1beddaa44345e7e79c6bb8ff5',
        '71d0615f04dc9b7d1f1ab5177dd5ae99b9372249e6979ab35892ca03cac0dcd8'),
    ('lab', ('ase_HELLO_25fps', 'tvq', 6)): ('27b5b9b92240606d1e23c647f7b2938ef07ac4bf4448adcb88c4a1a2828d4d49',
        '661a22573dee5d29f83d8f1e1ee20fcd6786feec4a1b5cccb22d59b704893aa2'),
    ('lab', ('ase_HELLO_25fps', 'posture', 1)): ('5f5472bebc365a11e8409aadaeaff36e438da5e7ec53015b94185529923cbe49',
        '31f8faa713ab1d2640bedb816a3efb38b83fc99671abdac0bd3e3b53ed6ee0fd'),
    ('lab', ('ase_HELLO_25fps', 'posture', 5)): ('a452418f5ad84db5e777a301035d40c720f94247eccb3e9051159e8c376341aa',
        '2f4b6f6d30579cc4d8ff5a0c88cb40fc9be162f990cbb1d2b24264df8d8bc98d'),
    ('lab', ('ase_HELLO_25fps', 'posture', 10)): ('920c092a37f3c4c5475caeee09629cc08e94a8af2d7495f58b27eada2e958b68',
        'f916de654f10432c27b3189265c6fe27a3a0755c29076fef9c39e6b23b92c0a7'),
    ('lab', ('ase_HELLO_25fps', 'gesture', 1)): ('7918d4be63823bc2877e80ac99811c0c45747315b209cd2d073e1f489fb83207',
        '5066514c253965c730832f1e7a62b6ef357e444f53d28fdf65282f0ab4d13ea5'),
    ('lab', ('ase_HELLO_25fps', 'gesture', 3)): ('4104a6ada4368073ec8d330322d76b79d566bc95df3e9ab42951567657a5ebba',
        'db28e388e03207d11a7878d4d8fe9b85589d260b2fab2c15dd7dfbfb7207c36a'),
    ('lab', ('ase_HELLO_25fps', 'gesture', 6)): ('6e830f1b1d4fb7131f6176399e9d0df04f1aa35e4c499941adfcb08ac49d9a63',
        '16ec429d2f3c2592f163a53940f72cd087c99d293cea872b9f876f8f29ccaef3'),
    ('lab', ('ase_HELLO_25fps', 'hybrid', 1)): ('1530e8f6dc95b524d37c214d80eba033ccd6252ca33ff2c129247b22e81b3d46',
        '8a47f76740b88168b4d72ca3e906e9c72e38773aa92bf90b2d1114e891c05c2a'),
    ('lab', ('ase_HELLO_25fps', 'hybrid', 4)): ('23f480e2f23cc54f0969bf6af098877d3fef1f91f114f8e364d7e43c8c2c6264',
        '3b545b90207a58095c3cb59dc26a86598596c4911ec1297e714f486fe689d8e6'),
    ('lab', ('ase_HELLO_25fps', 'hybrid', 8)): ('01b7f8d1b91ac7c084d9a536447ac2fe5f4dea9d9be5f92452a9366a0a138e41',
        '46db89c8f5c0683bbcd71bf76161dba21eb6760ff31d9da0ccee0e3da2ebe223'),
    ('lab', ('ase_J_10fps', 'quant', 1)): ('35015e2a10a0e3c3ce0173910f81a6001ca9e5507c5f5fec88ff96f0ba438f4e',
        'a33c3ec1527744c7ad3bbcf3a4d05f7739f6cab97ae58dd2efd7a5dabffdaaf6'),
    ('lab', ('ase_J_10fps', 'quant', 3)): ('290e251af2f2c72f6304feb7d18f4cd942283aaaf451e0ea3b03ac403b9b49bd',
        'd4ae3eb3d7d4f8ef390dc7bb18da5cfe9f28cadace7320f1f3263b4bf2a5da26'),
    ('lab', ('ase_J_10fps', 'quant', 6)): ('e2d74600d520b35b095273cac57712ad7184e1f8dc9fa77ff80f48b4e87b0e43',
        '08c31a33f152c7cd178d258e75f1dbd72c87c6c05a11cb7cc96b755853a970b9'),
    ('lab', ('ase_J_10fps', 'nuquant', 1)): ('954ffd17db7c41fc19fb2c02b8267a6ad677b9b78c38f212b0e9bacaf29b55ce',
        '165bb99ab998b1e12e97b53ad58a73a4c3afd688235cab309bad92c8d6f2234f'),
    ('lab', ('ase_J_10fps', 'nuquant', 3)): ('6023b8bd7326ff9861dc972da2b4b84a3dccc936a6ea51d7fe79dc5f9a6e676c',
        '38de3dca605fdf29a4c57531f8ddcc6acf4ab06513eb30e1fed96530ddde9511'),
    ('lab', ('ase_J_10fps', 'nuquant', 6)): ('af92d6baa1a09bd6a4a2c2252d1561fcf68b0edf4ee2c392766fd7547e28733f',
        '3cad4aaf5a9139675d496cc84ea4e62d42d7de876041acdc767421da2891cb4c'),
    ('lab', ('ase_J_10fps', 'dpcm', 1)): ('1adbd31eae85622c021efc244ea7d54bf0c426c63c8d190112a582a4b0e6bd57',
        '26ff81178e9429f3e337855df3f2d81d284973d53ae2ace13cad8374d30e01a5'),
    ('lab', ('ase_J_10fps', 'dpcm', 4)): ('20bac3d2f25ad76d4ea8a12ca55729aafb66a58a5bcb58392d9262796ea8b213',
        '97f7ea99b8d7bad692d6d4294207a3cf72f5fd2756d2abd9f5d9b5f2b5bb6e80'),
    ('lab', ('ase_J_10fps', 'dpcm', 7)): ('13dc69cd61bb337f447f7a88d5a4d0c236d2c887b56ed02965abc8cbacc28fe5',
        '2408c8b98183ba1390328fbf3f4a456349a0c709df8e7efce461ccf6c0b7dfe4'),
    ('lab', ('ase_J_10fps', 'adpcm', 1)): ('2ddf0b5705eaff4ca31be6e4b420e2bb93974558d65f12b913c70f3ecf8227ee',
        '9f9797d5548a8a28a80b43f8ed917f823a7b53927357cc732b3ed5fe543be91b'),
    ('lab', ('ase_J_10fps', 'adpcm', 4)): ('752fd166a3f21949454b40ef7ddfc9410eaafe63431395babd0a051af4cc074a',
        'cb55b5a4d5340ae41e29ecb88a9a1d627247d5fc4c21503f688e4194c5cb61d3'),
    ('lab', ('ase_J_10fps', 'adpcm', 7)): ('522358831eb9fa1c043b24ccbc2298841547f53eb1f8e712549ef9f4583e9308',
        'dd9714a70eec7920710a3c6653917a81f50f69a31cc3c3f6cc59d2ea0e5017cb'),
    ('lab', ('ase_J_10fps', 'deadreck', 1)): ('35be615791493bcc3fe04bca45f180486091396ca1a535e7e00056e97ef4bc20',
        'bce796e012e2b081afb46a3b538c544ae24a07a379ca3e2ab32ecea43ede338e'),
    ('lab', ('ase_J_10fps', 'deadreck', 4)): ('bbb199f1ceb4a5dd641367c1a4c30c76254702d16b5fa05c69377ddb6a666805',
        'aa082684dcabdb2b4f31ab8c09240fb959e490ff2d2720d605f8e7b6bea81262'),
    ('lab', ('ase_J_10fps', 'deadreck', 8)): ('4eff3e1a63eaeb67e99b090c67d7a00e763dc3859c2488fa022578a103c51d97',
        '579f0d5c99b9eccc3836610dd357edd6b04a653f817bfa03f4de5d4e214fe70e'),
    ('lab', ('ase_J_10fps', 'dct', 1)): ('02564953070f16f7186f9c1b1653f06c267ad4c6d91914b2bb590ac7186a1692',
        'c3ffc9b8a0debcb08030aa33f0f76e61b0396d03e1aea50b7e9c753b0b07c03f'),
    ('lab', ('ase_J_10fps', 'dct', 3)): ('cb913cd216747390de0d5fc2458d9d0cc331a2346e0323ff3c1a395f8086652d',
        '767c45b961c08b390b6eb4b5857fa59a3ca243d19f4223f41ceaf91c25d97c3e'),
    ('lab', ('ase_J_10fps', 'dct', 6)): ('bc5b3e6928a5df50c588671bc1988e57dd6092ae34eaaf7c1ddf205c333225e5',
        '8216afb8db7dcead83a8fe7111b582489842f8e038bde4c7c9b7c024e76b1c85'),
    ('lab', ('ase_J_10fps', 'wavelet', 1)): ('8f79215588717403a685a765830a2c740824aaf1aa31d9d04f2971482f2a1f61',
        '8be84e44f7dedc18021574c5cbefbb05447e91817b42774daf6ad5b8d6d27ee2'),
    ('lab', ('ase_J_10fps', 'wavelet', 4)): ('d6590040743bad2dff7b3b5806af3a017d06cade1fc6356fe13ae8670da4d95e',
        'bda87efbb2bcf207280f3b63e749752c495f79ef8a0bd4c66d0e50ba55fc82c2'),
    ('lab', ('ase_J_10fps', 'wavelet', 8)): ('d5b5d773a3a2fcb01cf7e0a6ae01cb0552fe132bb20a8f6daaac87dec480fe88',
        '0686ee2e41c2d2df35c63d81a8cdd9687e9afae989b373463d45ca2d55a3c182'),
    ('lab', ('ase_J_10fps', 'wavelet', 11)): ('786b01112cfaab6492dbf4f660b43da61a95f11158f4a8959d06f0da303bf6e1',
        '304673a955b8ac8891845fb44096a8245df3f4aeff22b3a483da1f8ab86f9836'),
    ('lab', ('ase_J_10fps', 'wavelet', 6)): ('88682e44b9749365242b28521242793f365d07d82729558a7326ae619791d52c',
        '037b41c4179aaba8d246426bc458bceedfbd8d2db5edef8ded4f3a2c6dd51e21'),
    ('lab', ('ase_J_10fps', 'svq', 1)): ('0894ad4b1c5a944e40a1c48bf7c293e35d3f7aef1ec2cdabe66485f80906553e',
        'a589413335c4aa369af08f7721f448690e31ffb224232824aee743c59a691e18'),
    ('lab', ('ase_J_10fps', 'svq', 3)): ('997a2949b0d24bb75e5fb60a56bcaad9bf3c5d8625ad170abf3baebf8a18aff7',
        'cf69da3e00c463e957b5e10cffa5ff20ebd923732f8e37071e2241520fd5a512'),
    ('lab', ('ase_J_10fps', 'svq', 6)): ('654ef25b6ec2f7e58ae39ce9a9428384194e20a47034919a48cebc530199c78d',
        'fcf77bce5923d2e15c4532c6c4c3991d8cf38141a3bc85a34217aaedf1968824'),
    ('lab', ('ase_J_10fps', 'tvq', 1)): ('df3ad6dc8524c484ddf3554be4dd8b15eb6b7a4082405711890254dbb933c74b',
        '1c5c6a17a784dedc5bb9e0e68a64447ded04c9ffe22d8e4345990bebd3a1404c'),
    ('lab', ('ase_J_10fps', 'tvq', 3)): ('74ba12c3c33996b22ed2c72897740bcb59edc2918fbaa8aab507973f796f4d26',
        'd39b51a76c428c9929185207112fa7f0989845ac4469f8e22ba4976b10191509'),
    ('lab', ('ase_J_10fps', 'tvq', 6)): ('bf783781973e99d674772fbaa1390ea3370adb6bc17358f766787e6079d4f2d7',
        '3f2ff50e2df50343c9ab514593bdfb28f6b3b5c870d275ae6f44c929d670993a'),
    ('lab', ('ase_J_10fps', 'posture', 1)): ('cd3b8c01897d61a1718a50e19bb59d74d644ed205c4fd8b96cec44592782643c',
        '4d9457f5f94920084ca1e4bd1e6a1ef5c8014bbb3742754bb97066628cd439f0'),
    ('lab', ('ase_J_10fps', 'posture', 5)): ('e5d6e327a25cb44582d7bb0db028fe6bd602c0be4121654101da7b55142835f6',
        'a065a19d4ba25c8e7740f00e6d0696ec5dd70de17827b2517b5f473bdf7cb6bc'),
    ('lab', ('ase_J_10fps', 'posture', 10)): ('d974462779eacdeecdc20abf5b75a5cd91cbbd94c9d408a74d37cc2d74c05db0',
        '01950b1aba0204c5e662d776eb54aa78a4d8e91010f3a8dff5b8dcdbf8fef2ce'),
    ('lab', ('ase_J_10fps', 'gesture', 1)): ('24f971b8216a11e32a59c4f0c8ac2112307dc512173fec7ebbd6490285231a8b',
        '5a23a57cf1286be5e21ec8e2899338ae78bcddaebcd08fac2d6e4d9a8bee3d24'),
    ('lab', ('ase_J_10fps', 'gesture', 3)): ('0de214a631d5a9db1ab4cb3a819bf7309916720a5bae6f9a08f0fd3db794378c',
        '47f2958162aacf60f965095b9fea6d4a7440cbdd74a08d65d56685051189f086'),
    ('lab', ('ase_J_10fps', 'gesture', 6)): ('2b5791c681dc2c09dc39c3a79d719bd3ed69ff0ea5abd6ec195dd10c1c840891',
        'd2791b19f27d627d1fa2e9ef006f4e4db0dbf1e72c0678b4d5943ec75bdb5087'),
    ('lab', ('ase_J_10fps', 'hybrid', 1)): ('1fb138437c181d1564b72aa7679335942888fc614f155932417b833f472f838d',
        'c5e3f6f9a6afcf72c3c17f5d211e07657293aa043f32737625c2f576e018ebcc'),
    ('lab', ('ase_J_10fps', 'hybrid', 4)): ('a0baf6db9225bce94067e6b685d098ea4c43939d1e9de78c778ad776d614dd3c',
        '1be307dfc6a67aa5b03671c7aeb0108a34d5316fa4ca13fb228f8b422c4c382e'),
    ('lab', ('ase_J_10fps', 'hybrid', 8)): ('e721bbfd5593c738a9748fe9792e0464afbc3e503f4fd86996dc658043d9aabd',
        'ec853600f0c988e4e5d4d4347782db31477f7d853b1b182f3041073d21be023a'),
    # wavelet-cx through LabCodec: its compact framing (comparisons/coded_streams.write_compact) and the shipped
    # context priors (comparisons/tables/context_priors.npz); retraining those changes these streams
    ('lab', ('ase_HELLO_25fps', 'wavelet-cx', 1)): ('a66b73f3339a89a246187cd0229143c6a6f399a2fc4451cfd426369ecbd538cb',
        'a3f30ff05e52e061c8113e26415097408e79fe7d0b3022629211bd5f1f216970'),
    ('lab', ('ase_HELLO_25fps', 'wavelet-cx', 6)): ('4d22fedc65a7b988beebe863968c3cf946222143bf495749d6908e5822148699',
        'fa0e8945e3bdb7973342d4902c0a6e1bb6e17bc6a55ba81792365e7f27fa0b85'),
    ('lab', ('ase_HELLO_25fps', 'wavelet-cx', 11)): ('9d29f60c912115b6d88106462a4a06d6c580556efe1b907047dfe6fa1f4d3fe6',
        '8c1236b15300a249fa39d55d2e1e5e5754396ca3253d6826a2c3515b4538713a'),
    ('lab', ('ase_J_10fps', 'wavelet-cx', 1)): ('0d6746164a1d543e2594697f03a9c74b1fb0a64b382c04bf5b9ad03b09ba6aba',
        '8be84e44f7dedc18021574c5cbefbb05447e91817b42774daf6ad5b8d6d27ee2'),
    ('lab', ('ase_J_10fps', 'wavelet-cx', 6)): ('97fc289153ef28b3143fb31f6502803c60309373aa178a35898d201c2c3137f1',
        '037b41c4179aaba8d246426bc458bceedfbd8d2db5edef8ded4f3a2c6dd51e21'),
    ('lab', ('ase_J_10fps', 'wavelet-cx', 11)): ('d60f289d45a33e985f54ab3e84d06531547020a5db740ea8e96ea090536d9603',
        '304673a955b8ac8891845fb44096a8245df3f4aeff22b3a483da1f8ab86f9836'),
}


@pytest.mark.parametrize("kind, arguments", list(all_cases()), ids=lambda v: str(v))
def test_streams_and_decoded_values_match_the_stored_references(kind, arguments):
    assert DIGESTS[kind](*arguments) == REFERENCE[(kind, arguments)]


# wavelet-cx (comparisons/lab/waveform.py ContextWaveletCoder): the coder's own stream (SCM1) over the clip's
# active DOFs and the shipped DOF ranges, as lab_codecs.LabCodec hands them to it (independent of the SCL1 wrapper's
# coder id, which comes with the name's registration in media.domain). (clip, q 1..11): (stream, decoded) SHA-256.
CONTEXT_WAVELET_REFERENCE = {
    ('ase_HELLO_25fps', 1): ('3a39f35da87ddc1b1708869b164ded31f376aba5571b98065ff71383d4fc6d4a',
        '09416fafdc2ed02d06e51e686c083eb151ce9a9f7b918c1c0c4ce489b5ead0e7'),
    ('ase_HELLO_25fps', 6): ('e9884b42554d5fdf9962926b48f059aaaf3002e06fdd914687ebf5723bc309c3',
        'cd12373b1e50b72a5a7be0912202ae4be29c5b32aeabcd45372f01920d15ad1d'),
    ('ase_HELLO_25fps', 11): ('d63d77ca898cf9c9187b94d89049a6cfbf8e75e7ff79492bab0a10389e7ddc23',
        'af3f2156dd9bf73b39deb9978204df9b404953942e8d0f9e3023a7a8f6482228'),
    ('ase_J_10fps', 1): ('1670986d9f4b6c86489f5056e0d94b3178c9ffdfed2d90c2a54f27346f4bec93',
        'b2a46b10ef5f84e5bef5b58900af79ea6486de5d6accdf91400bcb63ce36d608'),
    ('ase_J_10fps', 6): ('e24fae6b097214c82dc1015ee7791505717bf375ba22c1fae60b6488ca06fea9',
        '8e805b4b86eb10fd366ea49ab2f159029ed9b04219d8919e4d47c3f7b5897d24'),
    ('ase_J_10fps', 11): ('54460514715f25af759f56669a137bf880e0da5e3d2e9b9e0bcfa2d666a740a2',
        '2654c12d6098a35bf2e4f3487279909a58cadd672833f82f84fb71e21d96385e'),
}


@pytest.mark.parametrize("clip, q", sorted(CONTEXT_WAVELET_REFERENCE))
def test_context_wavelet_streams_match_the_stored_references(clip, q):
    from comparisons.lab.codecs import dof_ranges
    from comparisons.lab.waveform import ContextWaveletCoder
    lower, upper = dof_ranges()
    dofs = DOFS[clip]
    active = np.any(dofs != 0, axis=0)
    coder = ContextWaveletCoder(lower[active], upper[active])
    data, _ = coder.encode(dofs[:, active], MOTION_CLIPS[clip].fps, q - 1)
    assert (_sha(data), _sha(coder.decode(data))) == CONTEXT_WAVELET_REFERENCE[(clip, q)]
