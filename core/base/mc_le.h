/* Little-endian byte access, independent of the host's byte order: the
 * take and motion-graph files and the socket protocol store every number
 * little-endian.  Header-only, so that libmocap and the plugins use it
 * without linking the core.  The put functions return the byte after the
 * value written. */
#ifndef MC_LE_H
#define MC_LE_H

#include <stdint.h>
#include <string.h>

static inline uint8_t *mc_le_put_u16(uint8_t *p, uint16_t v)
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)(v >> 8);
	return p + 2;
}

static inline uint8_t *mc_le_put_u32(uint8_t *p, uint32_t v)
{
	for (int i = 0; i < 4; i++)
		p[i] = (uint8_t)(v >> (8 * i));
	return p + 4;
}

static inline uint8_t *mc_le_put_u64(uint8_t *p, uint64_t v)
{
	for (int i = 0; i < 8; i++)
		p[i] = (uint8_t)(v >> (8 * i));
	return p + 8;
}

static inline uint8_t *mc_le_put_f32(uint8_t *p, float f)
{
	uint32_t v;
	memcpy(&v, &f, 4);
	return mc_le_put_u32(p, v);
}

static inline uint8_t *mc_le_put_f64(uint8_t *p, double d)
{
	uint64_t v;
	memcpy(&v, &d, 8);
	return mc_le_put_u64(p, v);
}

static inline uint16_t mc_le_u16(const uint8_t *p)
{
	return (uint16_t)(p[0] | (p[1] << 8));
}

static inline uint32_t mc_le_u32(const uint8_t *p)
{
	return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static inline uint64_t mc_le_u64(const uint8_t *p)
{
	return (uint64_t)mc_le_u32(p) | ((uint64_t)mc_le_u32(p + 4) << 32);
}

static inline float mc_le_f32(const uint8_t *p)
{
	uint32_t v = mc_le_u32(p);
	float f;
	memcpy(&f, &v, 4);
	return f;
}

static inline double mc_le_f64(const uint8_t *p)
{
	uint64_t v = mc_le_u64(p);
	double d;
	memcpy(&d, &v, 8);
	return d;
}

#endif
