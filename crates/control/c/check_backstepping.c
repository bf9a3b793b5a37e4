/* Checks an exported flexstage backstepping controller against the Rust one on a recorded
 * sequence.
 *
 * Build with the controller's source, naming it by its prefix:
 *   cc -std=c99 -Wall -Wextra -Werror -pedantic -DCONTROLLER=robust \
 *      -DCONTROLLER_H='"robust.h"' check_backstepping.c robust.c -lm
 * and run it on the sequence the Rust controller recorded (flexstage-control's example
 * `export_check`): one header line; then per sample
 *   k, reading q1, q2 [m], index, the reference times of q1, q2 [s], the reference per
 *   derivative and axis (q_d, dq_d, ddq_d, dddq_d, each q1, q2, at those times),
 *   voltage 1, 2 [V], x_nom 1, 2 [m], saturated, dropout
 * The reference times PREFIX_reference_time(k, axis) gives must equal the recorded ones
 * bitwise, every voltage and x_nom must agree to 1e-12 relative (|c - r| <= 1e-12 |r|) and
 * the saturation and dropout flags exactly; the exit status is 0 only then. */
#include CONTROLLER_H

#include "check_common.h"

#define REFERENCE_TIME NAMED(CONTROLLER, _reference_time)
#define COLUMNS 20

int main(int argc, char **argv)
{
    char line[4096];
    FILE *f = open_sequence(argc, argv, line, sizeof line);
    STATE s;
    struct tally t = {0, 0, 0.0};
    if (f == NULL) {
        return 2;
    }
    INIT(&s);
    while (fgets(line, sizeof line, f) != NULL) {
        double v[COLUMNS], reference[4][2];
        int i;
        COMMAND c;
        if (read_columns(line, v, COLUMNS, t.n + 2) != 0) {
            return 2;
        }
        for (i = 0; i < 2; i++) {
            double when = REFERENCE_TIME((unsigned long)v[0], i);
            if (when != v[4 + i]) {
                if (t.bad < 5) {
                    fprintf(stderr, "sample %ld axis %d: reference time %.17g vs %.17g\n", t.n,
                            i + 1, when, v[4 + i]);
                }
                t.bad++;
            }
        }
        for (i = 0; i < 8; i++) {
            reference[i / 2][i % 2] = v[6 + i];
        }
        c = STEP(&s, &v[1], (const double(*)[2])reference, (unsigned long)v[3]);
        /* The recorded command: voltages v[14], v[15], x_nom v[16], v[17], flags v[18], v[19]. */
        compare_command(&t, c.voltage, c.x_nom, &v[14], &v[16]);
        if (c.saturated != (v[18] != 0.0) || c.dropout != (v[19] != 0.0)) {
            if (t.bad < 5) {
                fprintf(stderr, "sample %ld: saturated %d vs %g, dropout %d vs %g\n", t.n,
                        c.saturated, v[18], c.dropout, v[19]);
            }
            t.bad++;
        }
        t.n++;
    }
    fclose(f);
    return finish(&t);
}
