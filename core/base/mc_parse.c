#include "base/mc_parse.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

bool mc_parse_double(const char *s, double *out)
{
	char *end;
	errno = 0;
	double v = strtod(s, &end);
	if (errno || end == s || *end || !isfinite(v))
		return false;
	*out = v;
	return true;
}
