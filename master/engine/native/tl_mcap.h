/* The log's MCAP records laid out in bulk (tl_mcap.c, called by log/writer.py through ctypes): what the kernel
   exports for them. Each function's arrays and sizes are described at its definition. */
#ifndef TL_MCAP_H
#define TL_MCAP_H

#include <stdint.h>

/* n Message records, one after the other, into out. */
void tl_mcap_messages(int64_t n, const uint16_t *channel, const uint32_t *sequence, const uint64_t *log_time,
                      const int64_t *length, const int64_t *source, uint8_t *out);
/* A chunk's MessageIndex records into out; returns their number. */
int64_t tl_mcap_message_indexes(int64_t n, const uint16_t *channel, const uint64_t *log_time, const uint64_t *offset,
                                int64_t n_parts, const int64_t *part_ends, uint16_t *order, int64_t *at, uint8_t *out,
                                uint64_t *sizes);
/* Copy records of a batch into the chunk being filled, indexing them; returns the next record, or -1: no room. */
int64_t tl_mcap_fill(int64_t n, int64_t from, const uint8_t *blob, const int64_t *ends, const uint16_t *channel,
                     const uint64_t *log_time, int64_t chunk_size, uint8_t *chunk, int64_t capacity, int64_t *state,
                     uint16_t *ix_channel, uint64_t *ix_time, uint64_t *ix_offset, int64_t *part_ends,
                     int64_t index_capacity);

#endif
