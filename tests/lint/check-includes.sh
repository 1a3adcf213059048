#!/bin/sh
# The one-way include rule of core/ (core/README.md): a file in core/DIR
# may include headers of DIR itself and of the folders listed before DIR,
# never of a later one; and nothing in core/ includes from daemon/, ipc/,
# drivers/ or tools/.  Exit 0 when the tree keeps the rule, 1 with every
# offending line otherwise.  Usage: check-includes.sh [ROOT]
cd "${1:-$(dirname "$0")/../..}" || exit 2
order="base geom body image ring energy track eval motion"
rank() { i=0; for d in $order; do [ "$d" = "$1" ] && { echo $i; return; }; i=$((i + 1)); done; echo -1; }
bad=0
for dir in $order; do
	[ -d "core/$dir" ] || { echo "check-includes: core/$dir is missing"; bad=1; continue; }
	mine=$(rank "$dir")
	for f in core/"$dir"/*.c core/"$dir"/*.h core/"$dir"/*.cpp; do
		[ -f "$f" ] || continue
		grep -n '^#include "' "$f" | while IFS= read -r line; do
			inc=$(echo "$line" | sed 's/.*#include "\([^"]*\)".*/\1/')
			case "$inc" in
			*/*) top=${inc%%/*} ;;
			*) top=$dir ;; # a header of the same folder
			esac
			r=$(rank "$top")
			if [ "$r" -lt 0 ]; then
				echo "$f:${line%%:*}: includes \"$inc\", which is not a core folder"
			elif [ "$r" -gt "$mine" ]; then
				echo "$f:${line%%:*}: core/$dir includes \"$inc\" from the later layer core/$top"
			fi
		done
	done
done >/tmp/check-includes.$$ 2>&1
for f in core/*.c core/*.h; do
	[ -f "$f" ] && echo "$f: a core file outside the layer folders" >>/tmp/check-includes.$$
done
if [ -s /tmp/check-includes.$$ ]; then
	cat /tmp/check-includes.$$
	bad=1
fi
rm -f /tmp/check-includes.$$
[ "$bad" -eq 0 ] && echo "check-includes: core/ keeps the one-way include rule ($order)"
exit "$bad"
