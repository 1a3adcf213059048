/* tree: running mocapd from its build tree.  A mocapd started as
 * <build>/bin/mocapd of a source checkout takes its driver plugins from
 * <build>/drivers unless the command line or the config names a plugin
 * directory, so that `build/bin/mocapd --config config/demo.conf` works
 * without --plugin-dir (issue 31 item 8). */
#ifndef MCD_TREE_H
#define MCD_TREE_H

#include <stdbool.h>
#include <stddef.h>

/* The build tree's plugin directory when `exe` (normally /proc/self/exe
 * resolved) is <build>/bin/NAME, <build>/drivers holds at least one
 * mocap-driver-*.so and <build>/.. is a source tree (has daemon/main.c);
 * false otherwise. */
bool mcd_tree_plugin_dir(const char *exe, char *out, size_t cap);

/* The same for the running program. */
bool mcd_tree_plugin_dir_self(char *out, size_t cap);

#endif
