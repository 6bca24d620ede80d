/* tools/cli/auto_table.c — PROVISIONAL (before the first bench/pareto run):
 * replaced by the generated table (bench/pareto/plot.py --auto-table). */
#include "pareto_math.h"

const pareto_auto_row pareto_auto_table[] = {
    {"pathtrace", 20, 2100, 0.05, 1},
    {"shaded", 5, 300, 1.0, 0},
};
const int pareto_auto_table_rows = (int)(sizeof pareto_auto_table / sizeof pareto_auto_table[0]);
