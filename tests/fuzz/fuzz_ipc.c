/* libFuzzer target: the protocol decoder that mocapd's server runs on every
 * datagram a client sends (and libmocap on every datagram from the server).
 *
 * Besides "no crash, no leak, no undefined behaviour", it checks two
 * properties on every input:
 *   - a refused input always comes with a reason (the server sends it to
 *     the client in its ERROR reply);
 *   - an accepted input re-encodes to a message of the same size, and that
 *     encoding decodes and re-encodes to identical bytes (the encoder and
 *     the decoder agree on every field's offset). */
#include "proto.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static proto_msg msg, msg2;
static uint8_t enc[PROTO_MAX_MESSAGE], enc2[PROTO_MAX_MESSAGE];

static void fail(const char *what, size_t size)
{
	fprintf(stderr, "fuzz_ipc: %s (input of %zu bytes)\n", what, size);
	abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	for (int dir = 0; dir < 2; dir++) {
		char why[256];
		why[0] = 0;
		if (proto_decode(data, size, (proto_direction)dir, &msg, why, sizeof(why)) != 0) {
			if (!why[0])
				fail("refused without a reason", size);
			continue;
		}
		size_t n = proto_encode(&msg, enc, sizeof(enc));
		if (n != size)
			fail("re-encoded size differs from the input's", size);
		if (proto_decode(enc, n, (proto_direction)dir, &msg2, why, sizeof(why)) != 0)
			fail("re-encoded message does not decode", size);
		size_t n2 = proto_encode(&msg2, enc2, sizeof(enc2));
		if (n2 != n || memcmp(enc, enc2, n) != 0)
			fail("encoding is not stable", size);
	}
	return 0;
}
