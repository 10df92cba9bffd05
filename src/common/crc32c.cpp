#include "common/crc32c.h"

#include <array>
#include <cstring>

#if defined(__x86_64__)
#include <nmmintrin.h>
#endif

namespace landmark_loop_closure {

namespace {

constexpr uint32_t kPolynomial = 0x82F63B78u;  // Castagnoli, reflected.

using Tables = std::array<std::array<uint32_t, 256>, 8>;

Tables makeTables() {
  Tables tables{};
  for (uint32_t n = 0; n < 256; ++n) {
    uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? kPolynomial ^ (c >> 1) : c >> 1;
    tables[0][n] = c;
  }
  for (uint32_t n = 0; n < 256; ++n) {
    for (size_t t = 1; t < 8; ++t) {
      tables[t][n] = (tables[t - 1][n] >> 8) ^ tables[0][tables[t - 1][n] & 0xFFu];
    }
  }
  return tables;
}

#if defined(__x86_64__)
__attribute__((target("sse4.2"))) uint32_t crc32cHardwareSerial(uint32_t crc, const uint8_t* data,
                                                                size_t size) {
  uint64_t value = ~crc;
  for (; size >= 8; size -= 8, data += 8) {
    uint64_t word = 0;
    std::memcpy(&word, data, 8);
    value = _mm_crc32_u64(value, word);
  }
  uint32_t value32 = static_cast<uint32_t>(value);
  for (; size > 0; --size, ++data) value32 = _mm_crc32_u8(value32, *data);
  return ~value32;
}

// The instruction has a latency of three cycles but can start every cycle: three independent
// streams over the thirds of a large buffer run about three times faster, and their CRCs
// combine into the whole's.
__attribute__((target("sse4.2"))) uint32_t crc32cHardware(uint32_t crc, const uint8_t* data,
                                                          size_t size) {
  constexpr size_t kMinInterleaved = 3 * 4096;
  if (size < kMinInterleaved) return crc32cHardwareSerial(crc, data, size);
  const size_t third = (size / 3) & ~size_t{7};
  const uint8_t* second = data + third;
  const uint8_t* last = data + 2 * third;
  uint64_t a = ~crc;
  uint64_t b = 0xFFFFFFFFu;
  uint64_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < third; i += 8) {
    uint64_t word_a = 0;
    uint64_t word_b = 0;
    uint64_t word_c = 0;
    std::memcpy(&word_a, data + i, 8);
    std::memcpy(&word_b, second + i, 8);
    std::memcpy(&word_c, last + i, 8);
    a = _mm_crc32_u64(a, word_a);
    b = _mm_crc32_u64(b, word_b);
    c = _mm_crc32_u64(c, word_c);
  }
  const uint32_t crc_a = ~static_cast<uint32_t>(a);
  const uint32_t crc_b = ~static_cast<uint32_t>(b);
  const uint32_t crc_c =
      crc32cHardwareSerial(~static_cast<uint32_t>(c), last + third, size - 3 * third);
  return crc32cCombine(crc32cCombine(crc_a, crc_b, third), crc_c, size - 2 * third);
}
#endif

}  // namespace

uint32_t crc32cPortable(uint32_t crc, const uint8_t* data, size_t size) {
  static const Tables tables = makeTables();
  uint32_t value = ~crc;
  // Slicing by 8 reads whole words: the byte order below is little-endian's.
  for (; size >= 8; size -= 8, data += 8) {
    const uint32_t low =
        value ^ (static_cast<uint32_t>(data[0]) | static_cast<uint32_t>(data[1]) << 8 |
                 static_cast<uint32_t>(data[2]) << 16 | static_cast<uint32_t>(data[3]) << 24);
    value = tables[7][low & 0xFFu] ^ tables[6][(low >> 8) & 0xFFu] ^
            tables[5][(low >> 16) & 0xFFu] ^ tables[4][low >> 24] ^ tables[3][data[4]] ^
            tables[2][data[5]] ^ tables[1][data[6]] ^ tables[0][data[7]];
  }
  for (; size > 0; --size, ++data) value = tables[0][(value ^ *data) & 0xFFu] ^ (value >> 8);
  return ~value;
}

namespace {

// Product of two polynomials modulo the (reflected) CRC polynomial: bit 31 holds x^0.
uint32_t multiplyModPolynomial(uint32_t a, uint32_t b) {
  uint32_t product = 0;
  for (uint32_t bit = 1u << 31; bit != 0; bit >>= 1) {
    if (a & bit) product ^= b;
    b = (b & 1u) ? (b >> 1) ^ kPolynomial : b >> 1;
  }
  return product;
}

// x^(8 * bytes) modulo the polynomial, by squaring: appending `bytes` zero bytes multiplies the
// register by it.
uint32_t shiftForBytes(uint64_t bytes) {
  uint32_t result = 1u << 31;  // x^0
  uint32_t square = 1u << 23;  // x^8: one byte
  for (; bytes != 0; bytes >>= 1) {
    if (bytes & 1u) result = multiplyModPolynomial(square, result);
    square = multiplyModPolynomial(square, square);
  }
  return result;
}

}  // namespace

uint32_t crc32cCombine(uint32_t crc_first, uint32_t crc_second, uint64_t second_bytes) {
  // The pre- and post-inversions of both parts cancel out: only the raw register moves.
  return multiplyModPolynomial(shiftForBytes(second_bytes), crc_first) ^ crc_second;
}

uint32_t crc32c(uint32_t crc, const uint8_t* data, size_t size) {
#if defined(__x86_64__)
  static const bool hardware = __builtin_cpu_supports("sse4.2");
  if (hardware) return crc32cHardware(crc, data, size);
#endif
  return crc32cPortable(crc, data, size);
}

}  // namespace landmark_loop_closure
