/**
 * @file forte_crc.h
 * @brief CRC-16/CCITT-FALSE used by every FORTE frame.
 *
 * Parameters: width 16, polynomial 0x1021, initial value 0xFFFF, no input or output
 * reflection, no final XOR. Check value (CRC of the ASCII bytes "123456789") = 0x29B1.
 * Python's binascii.crc_hqx(data, 0xFFFF) computes the same function.
 */
#ifndef FORTE_CRC_H
#define FORTE_CRC_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** Initial register value of CRC-16/CCITT-FALSE. */
#define FORTE_CRC16_INIT 0xFFFFu

/**
 * Continue a CRC-16/CCITT-FALSE over @p length more bytes.
 *
 * @param crc    register value so far (FORTE_CRC16_INIT to start)
 * @param data   bytes to add (may be NULL when length is 0)
 * @param length number of bytes
 * @return the updated register value (the CRC once all bytes are added)
 */
uint16_t forte_crc16_update(uint16_t crc, const uint8_t *data, size_t length);

/** CRC-16/CCITT-FALSE of a whole buffer. */
uint16_t forte_crc16(const uint8_t *data, size_t length);

#ifdef __cplusplus
}
#endif

#endif /* FORTE_CRC_H */
