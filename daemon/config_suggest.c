/* config_suggest: "did you mean" for an unknown key or section of
 * mocapd.conf, from the key table (config_keys.c): the known name closest
 * in edits, if it is close enough to be the one meant. */
#include "config.h"

#include <ctype.h>
#include <stdbool.h>
#include <string.h>

/* Damerau-Levenshtein (optimal string alignment) distance, case folded;
 * names are short (< MCD_NAME_MAX). */
static int distance(const char *a, const char *b)
{
	int la = (int)strlen(a), lb = (int)strlen(b);
	if (la >= MCD_NAME_MAX || lb >= MCD_NAME_MAX)
		return 1 << 20;
	static __thread int d[MCD_NAME_MAX + 1][MCD_NAME_MAX + 1];
	for (int i = 0; i <= la; i++)
		d[i][0] = i;
	for (int j = 0; j <= lb; j++)
		d[0][j] = j;
	for (int i = 1; i <= la; i++)
		for (int j = 1; j <= lb; j++) {
			int cost = tolower((unsigned char)a[i - 1]) != tolower((unsigned char)b[j - 1]);
			int v = d[i - 1][j] + 1;
			if (d[i][j - 1] + 1 < v)
				v = d[i][j - 1] + 1;
			if (d[i - 1][j - 1] + cost < v)
				v = d[i - 1][j - 1] + cost;
			if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] && d[i - 2][j - 2] + 1 < v)
				v = d[i - 2][j - 2] + 1; /* two letters swapped */
			d[i][j] = v;
		}
	return d[la][lb];
}

/* Close enough to be a typo: a third of the name's letters, at least 1,
 * at most 3. */
static bool close_enough(const char *typed, int dist)
{
	int allowed = (int)strlen(typed) / 3;
	allowed = allowed < 1 ? 1 : allowed > 3 ? 3 : allowed;
	return dist <= allowed;
}

const char *mcd_suggest_name(const char *typed, const char *names, size_t stride, int n)
{
	const char *best = NULL;
	int best_d = 1 << 20;
	for (int i = 0; i < n; i++) {
		const char *name = names + (size_t)i * stride;
		int dist = distance(typed, name);
		if (dist < best_d) {
			best_d = dist;
			best = name;
		}
	}
	return best && close_enough(typed, best_d) ? best : NULL;
}

const char *mcd_config_suggest_key(mcd_section section, const char *key)
{
	const char *best = NULL;
	int best_d = 1 << 20;
	size_t n = 0;
	const mcd_config_key *keys = mcd_config_keys(&n);
	for (size_t i = 0; i < n; i++) {
		const mcd_config_key *k = &keys[i];
		if (k->section != section)
			continue;
		int dist = distance(key, k->key);
		if (dist < best_d) {
			best_d = dist;
			best = k->key;
		}
	}
	return best && close_enough(key, best_d) ? best : NULL;
}

const char *mcd_config_suggest_section(const char *name)
{
	const char *best = NULL;
	int best_d = 1 << 20;
	/* "[camera left]" misspelt: compare the first word */
	char word[MCD_NAME_MAX];
	size_t n = strcspn(name, " ");
	if (n >= sizeof(word))
		return NULL;
	memcpy(word, name, n);
	word[n] = 0;
	for (int s = 0; s < MCD_NSECTIONS; s++) {
		int dist = distance(word, mcd_section_name((mcd_section)s));
		if (dist < best_d) {
			best_d = dist;
			best = mcd_section_name((mcd_section)s);
		}
	}
	return best && close_enough(word, best_d) ? best : NULL;
}
