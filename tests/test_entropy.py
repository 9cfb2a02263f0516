"""Adaptive arithmetic coder, canonical Huffman coder and the bit stream they write into."""
import numpy as np
import pytest

from comparisons.params.bits import BitReader, BitWriter, find_start_codes
from comparisons.params.entropy import (ArithmeticDecoder, ArithmeticEncoder, CanonicalHuffman, FrequencyModel,
                                 decode_sequence, empirical_entropy_bits, encode_sequence, huffman_code_lengths)
from media.errors import SigncastError


def _laplace_symbols(n, scale=3.0, half=40, seed=0):
    rng = np.random.default_rng(seed)
    return (np.clip(np.round(rng.laplace(0, scale, n)), -half, half).astype(int) + half).tolist()


def test_arithmetic_coder_round_trips_and_reaches_empirical_entropy():
    symbols = _laplace_symbols(20000)
    data = encode_sequence(symbols, 81)
    assert decode_sequence(data, 81) == symbols
    coded_bits = 8 * len(data) - 32          # minus the count header
    assert coded_bits <= 1.03 * empirical_entropy_bits(symbols)


def test_arithmetic_coder_handles_skewed_and_single_symbol_alphabets():
    symbols = [0] * 5000 + [1] * 3 + [0] * 100
    data = encode_sequence(symbols, 2)
    assert decode_sequence(data, 2) == symbols
    assert len(data) < 20                    # a near-certain symbol costs almost nothing
    assert decode_sequence(encode_sequence([0] * 50, 1), 1) == [0] * 50


def test_frequency_model_halves_counts_at_its_limit_and_stays_decodable():
    symbols = _laplace_symbols(3000, scale=1.0, half=3, seed=1)
    writer = BitWriter()
    encoder = ArithmeticEncoder(writer)
    model = FrequencyModel(7, increment=32, limit=1024)
    for s in symbols:
        encoder.encode(model, s)
    encoder.finish()
    assert model.total <= 1024
    decoder_model = FrequencyModel(7, increment=32, limit=1024)
    decoder = ArithmeticDecoder(BitReader(writer.getvalue()))
    assert [decoder.decode(decoder_model) for _ in symbols] == symbols


def test_arithmetic_decoder_hands_back_lookahead_bits_to_the_next_field():
    writer = BitWriter()
    encoder = ArithmeticEncoder(writer)
    model = FrequencyModel(10)
    for s in [3, 1, 4, 1, 5, 9, 2, 6]:
        encoder.encode(model, s)
    encoder.finish()
    writer.write(0b1011001110, 10)
    reader = BitReader(writer.getvalue())
    decoder = ArithmeticDecoder(reader)
    model = FrequencyModel(10)
    assert [decoder.decode(model) for _ in range(8)] == [3, 1, 4, 1, 5, 9, 2, 6]
    decoder.finish()
    assert reader.read(10) == 0b1011001110


@pytest.mark.parametrize("damage", ["truncate", "trailing"])
def test_arithmetic_sequence_rejects_truncated_or_padded_data(damage):
    data = encode_sequence(_laplace_symbols(500), 81)
    bad = data[:-2] if damage == "truncate" else data + b"\x00"
    with pytest.raises(SigncastError):
        decode_sequence(bad, 81)


def test_encoder_rejects_symbol_outside_alphabet():
    with pytest.raises(SigncastError):
        ArithmeticEncoder(BitWriter()).encode(FrequencyModel(4), 4)


def test_huffman_lengths_are_optimal_for_dyadic_frequencies_and_decode_back():
    lengths = huffman_code_lengths([8, 4, 2, 1, 1, 0])
    assert lengths == [1, 2, 3, 4, 4, 0]
    code = CanonicalHuffman(lengths)
    writer = BitWriter()
    message = [0, 3, 2, 1, 4, 0, 0]
    for s in message:
        code.encode(writer, s)
    reader = BitReader(writer.getvalue())
    assert [code.decode(reader) for _ in message] == message
    with pytest.raises(SigncastError):
        code.encode(writer, 5)


def test_huffman_respects_the_length_limit_and_kraft():
    lengths = huffman_code_lengths([2 ** k for k in range(30)], max_length=12)
    assert max(lengths) <= 12
    assert sum(2.0 ** -x for x in lengths) <= 1.0
    with pytest.raises(SigncastError):
        CanonicalHuffman([1, 1, 1])


def test_huffman_decoder_rejects_truncated_bits():
    code = CanonicalHuffman(huffman_code_lengths([5, 3, 1, 1]))
    with pytest.raises(SigncastError):
        code.decode(BitReader(b""))


def test_start_codes_are_never_emulated_by_coded_zeros():
    writer = BitWriter()
    writer.start_code(0xB0)
    for _ in range(200):
        writer.write_bit(0)
    writer.start_code(0xB1)
    data = writer.getvalue()
    assert [code for _, code in find_start_codes(data)] == [0xB0, 0xB1]
    reader = BitReader(data)
    assert reader.read_start_code() == 0xB0
    assert reader.read(200) == 0
    assert reader.at_start_code() and reader.read_start_code() == 0xB1
