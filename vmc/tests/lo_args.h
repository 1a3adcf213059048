/* Reading liblo message arguments in the VMC test and benchmark: liblo's
 * arguments are 4-byte aligned, its lo_arg union wants 8, so they are read
 * by their bytes (UBSan: misaligned member access). */
#ifndef VMC_LO_ARGS_H
#define VMC_LO_ARGS_H

#include <lo/lo.h>
#include <stdint.h>
#include <string.h>

static inline float lo_arg_float(const lo_arg *a)
{
	float f;
	memcpy(&f, a, sizeof(f));
	return f;
}

static inline int32_t lo_arg_int(const lo_arg *a)
{
	int32_t i;
	memcpy(&i, a, sizeof(i));
	return i;
}

#endif
