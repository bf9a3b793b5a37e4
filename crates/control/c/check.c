/* Checks an exported flexstage controller against the Rust one on a recorded sequence.
 *
 * Build with the controller's source, naming it by its prefix:
 *   cc -std=c99 -Wall -Wextra -Werror -pedantic -DCONTROLLER=pi_notch_ff \
 *      -DCONTROLLER_H='"pi_notch_ff.h"' check.c pi_notch_ff.c -lm
 * and run it on the sequence the Rust controller recorded (flexstage-control's example
 * `export_check`): one header line; then the reference samples primed into the FIR before
 * the first step, one per line as `p,q1,q2` [m]; then per sample
 *   ahead q1, q2 [m], reference q1, q2 [m], reading q1, q2 [m], index,
 *   voltage 1, 2 [V], x_nom 1, 2 [m], saturated
 * Every voltage and x_nom must agree to 1e-12 relative (|c - r| <= 1e-12 |r|) and the
 * saturation flag exactly; the exit status is 0 only then. */
#include CONTROLLER_H

#include "check_common.h"

#define PRIME NAMED(CONTROLLER, _prime)

int main(int argc, char **argv)
{
    char line[2048];
    FILE *f = open_sequence(argc, argv, line, sizeof line);
    STATE s;
    struct tally t = {0, 0, 0.0};
    if (f == NULL) {
        return 2;
    }
    INIT(&s);
    while (fgets(line, sizeof line, f) != NULL) {
        double v[12];
        COMMAND c;
        if (line[0] == 'p' && line[1] == ',') {
            if (read_columns(line + 2, v, 2, t.n + 2) != 0) {
                return 2;
            }
            PRIME(&s, &v[0]);
            continue;
        }
        if (read_columns(line, v, 12, t.n + 2) != 0) {
            return 2;
        }
        c = STEP(&s, &v[0], &v[2], &v[4], (unsigned long)v[6]);
        /* The recorded command: voltages v[7], v[8], x_nom v[9], v[10], saturated v[11]. */
        compare_command(&t, c.voltage, c.x_nom, &v[7], &v[9]);
        if (c.saturated != (v[11] != 0.0)) {
            if (t.bad < 5) {
                fprintf(stderr, "sample %ld: saturated %d vs %g\n", t.n, c.saturated, v[11]);
            }
            t.bad++;
        }
        t.n++;
    }
    fclose(f);
    return finish(&t);
}
