/**
 * @file forte_crc.c
 * @brief CRC-16/CCITT-FALSE, nibble-table implementation (32 bytes of table, no
 *        start-up initialisation, safe to call from an interrupt).
 */
#include "forte_crc.h"

/* crc_table[n] = CRC register contribution of the 4-bit value n shifted through 0x1021. */
static const uint16_t crc_nibble_table[16] = {
    0x0000u, 0x1021u, 0x2042u, 0x3063u, 0x4084u, 0x50A5u, 0x60C6u, 0x70E7u,
    0x8108u, 0x9129u, 0xA14Au, 0xB16Bu, 0xC18Cu, 0xD1ADu, 0xE1CEu, 0xF1EFu,
};

uint16_t forte_crc16_update(uint16_t crc, const uint8_t *data, size_t length)
{
    for (size_t i = 0; i < length; ++i) {
        const uint8_t byte = data[i];
        crc = (uint16_t)((crc << 4) ^ crc_nibble_table[((crc >> 12) ^ (byte >> 4)) & 0x0Fu]);
        crc = (uint16_t)((crc << 4) ^ crc_nibble_table[((crc >> 12) ^ (byte & 0x0Fu)) & 0x0Fu]);
    }
    return crc;
}

uint16_t forte_crc16(const uint8_t *data, size_t length)
{
    return forte_crc16_update((uint16_t)FORTE_CRC16_INIT, data, length);
}
