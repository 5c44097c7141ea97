/* MCAP records laid out in bulk for the log's writer (log/writer.py): Message records of a batch in file order,
   and the MessageIndex records of a chunk. Byte for byte what the mcap library's record classes write (little
   endian, MCAP specification), without a Python call per record. The caller owns every array. */
#include "tl_mcap.h"

#include <stdint.h>
#include <string.h>

#if defined(__GNUC__)
#define TL_EXPORT __attribute__((visibility("default")))
#else
#define TL_EXPORT
#endif

#define MESSAGE_OPCODE 0x05
#define MESSAGE_INDEX_OPCODE 0x07
#define MESSAGE_HEADER 31 /* opcode, record length, channel, sequence, log time, publish time */

static uint8_t *put(uint8_t *at, uint64_t value, int bytes) {
    for (int i = 0; i < bytes; i++) at[i] = (uint8_t)(value >> (8 * i));
    return at + bytes;
}

/* n Message records, one after the other, into out (room for sum(31 + length) bytes): message i on channel[i] with
   sequence[i], log and publish time log_time[i], and the length[i] payload bytes at address source[i]. */
TL_EXPORT void tl_mcap_messages(int64_t n, const uint16_t *channel, const uint32_t *sequence, const uint64_t *log_time,
                                const int64_t *length, const int64_t *source, uint8_t *out) {
    for (int64_t i = 0; i < n; i++) {
        out = put(out, MESSAGE_OPCODE, 1);
        out = put(out, (uint64_t)(22 + length[i]), 8);
        out = put(out, channel[i], 2);
        out = put(out, sequence[i], 4);
        out = put(out, log_time[i], 8);
        out = put(out, log_time[i], 8);
        if (length[i]) memcpy(out, (const void *)(intptr_t)source[i], (size_t)length[i]);
        out += length[i];
    }
}

/* A chunk's MessageIndex records into out (room for 15 per channel + 16 n bytes): one per channel, the channels in
   order of first appearance, by number within a part (part k: messages part_ends[k - 1]..part_ends[k], as the writer
   appended them), each listing (log time, offset in the chunk) of its messages as they come. order[k], at[k]: the
   k-th record's channel and where it starts in out (room for as many channels as the chunk has). Returns the number
   of records; sizes[0], the bytes written; sizes[1], sizes[2]: the chunk's first and last log time. */
TL_EXPORT int64_t tl_mcap_message_indexes(int64_t n, const uint16_t *channel, const uint64_t *log_time,
                                          const uint64_t *offset, int64_t n_parts, const int64_t *part_ends,
                                          uint16_t *order, int64_t *at, uint8_t *out, uint64_t *sizes) {
    int64_t n_channels = 0, from = 0;
    uint64_t first = n ? log_time[0] : 0, last = first;
    for (int64_t i = 1; i < n; i++) {
        if (log_time[i] < first) first = log_time[i];
        if (log_time[i] > last) last = log_time[i];
    }
    for (int64_t p = 0; p < n_parts; from = part_ends[p++]) {
        int64_t first_new = n_channels;
        for (int64_t i = from; i < part_ends[p]; i++) {
            int64_t k = 0;
            while (k < n_channels && order[k] != channel[i]) k++;
            if (k < n_channels) continue;
            int64_t j = n_channels++; /* insert among this part's new channels, by number */
            while (j > first_new && order[j - 1] > channel[i]) {
                order[j] = order[j - 1];
                j--;
            }
            order[j] = channel[i];
        }
    }
    uint8_t *start = out;
    for (int64_t k = 0; k < n_channels; k++) {
        uint64_t count = 0;
        for (int64_t i = 0; i < n; i++) count += channel[i] == order[k];
        at[k] = out - start;
        out = put(out, MESSAGE_INDEX_OPCODE, 1);
        out = put(out, 2 + 4 + 16 * count, 8);
        out = put(out, order[k], 2);
        out = put(out, 16 * count, 4);
        for (int64_t i = 0; i < n; i++) {
            if (channel[i] != order[k]) continue;
            out = put(out, log_time[i], 8);
            out = put(out, offset[i], 8);
        }
    }
    sizes[0] = (uint64_t)(out - start), sizes[1] = first, sizes[2] = last;
    return n_channels;
}

/* One part of the chunk being filled: records from, from + 1, ... of a batch (laid out in blob; record i ends at
   ends[i], the first starts at 0) copied to chunk + state[0], until the chunk holds chunk_size bytes or more (at least
   one record) or the batch ends; their channel, log time and offset in the chunk appended to the index arrays at
   state[1], and the part's end to part_ends[state[2]]. state: bytes in the chunk, its messages, its parts. Returns
   the next record to copy, or -1 when the chunk (capacity bytes) or the index arrays (index_capacity messages, as many
   parts) have no room: nothing was copied then. */
TL_EXPORT int64_t tl_mcap_fill(int64_t n, int64_t from, const uint8_t *blob, const int64_t *ends, const uint16_t *channel,
                               const uint64_t *log_time, int64_t chunk_size, uint8_t *chunk, int64_t capacity,
                               int64_t *state, uint16_t *ix_channel, uint64_t *ix_time, uint64_t *ix_offset,
                               int64_t *part_ends, int64_t index_capacity) {
    int64_t base = from ? ends[from - 1] : 0, filled = state[0], stop = from;
    while (stop < n && (stop == from || filled + (ends[stop - 1] - base) < chunk_size)) stop++;
    int64_t bytes = ends[stop - 1] - base, count = state[1];
    if (filled + bytes > capacity || count + (stop - from) > index_capacity || state[2] >= index_capacity) return -1;
    memcpy(chunk + filled, blob + base, (size_t)bytes);
    for (int64_t i = from; i < stop; i++, count++) {
        ix_channel[count] = channel[i];
        ix_time[count] = log_time[i];
        ix_offset[count] = (uint64_t)(filled + (i ? ends[i - 1] : 0) - base);
    }
    state[0] = filled + bytes, state[1] = count;
    part_ends[state[2]++] = count;
    return stop;
}
