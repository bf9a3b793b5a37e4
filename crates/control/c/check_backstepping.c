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
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include CONTROLLER_H

#define CAT(a, b) a##b
#define NAMED(a, b) CAT(a, b)
#define STATE NAMED(CONTROLLER, _state)
#define COMMAND NAMED(CONTROLLER, _command)
#define INIT NAMED(CONTROLLER, _init)
#define STEP NAMED(CONTROLLER, _step)
#define REFERENCE_TIME NAMED(CONTROLLER, _reference_time)
#define STR(a) #a
#define NAME(a) STR(a)

#define TOLERANCE 1e-12
#define COLUMNS 20

static double relative(double c, double r)
{
    double d = fabs(c - r);
    if (d == 0.0) {
        return 0.0;
    }
    return r == 0.0 ? INFINITY : d / fabs(r);
}

int main(int argc, char **argv)
{
    char line[4096];
    FILE *f;
    STATE s;
    long n = 0, bad = 0;
    double worst = 0.0;
    if (argc != 2) {
        fprintf(stderr, "usage: %s SEQUENCE.csv\n", argv[0]);
        return 2;
    }
    f = fopen(argv[1], "r");
    if (f == NULL || fgets(line, sizeof line, f) == NULL) {
        fprintf(stderr, "cannot read %s\n", argv[1]);
        return 2;
    }
    INIT(&s);
    while (fgets(line, sizeof line, f) != NULL) {
        double v[COLUMNS], reference[4][2];
        char *p = line, *end;
        int i;
        COMMAND c;
        for (i = 0; i < COLUMNS; i++) {
            v[i] = strtod(p, &end);
            if (end == p) {
                fprintf(stderr, "line %ld: column %d is not a number\n", n + 2, i + 1);
                return 2;
            }
            p = end;
            if (*p == ',') {
                p++;
            }
        }
        for (i = 0; i < 2; i++) {
            double t = REFERENCE_TIME((unsigned long)v[0], i);
            if (t != v[4 + i]) {
                if (bad < 5) {
                    fprintf(stderr, "sample %ld axis %d: reference time %.17g vs %.17g\n", n,
                            i + 1, t, v[4 + i]);
                }
                bad++;
            }
        }
        for (i = 0; i < 8; i++) {
            reference[i / 2][i % 2] = v[6 + i];
        }
        c = STEP(&s, &v[1], (const double(*)[2])reference, (unsigned long)v[3]);
        /* The recorded command: voltages v[14], v[15], x_nom v[16], v[17], flags v[18], v[19]. */
        for (i = 0; i < 2; i++) {
            double rv = relative(c.voltage[i], v[14 + i]);
            double rx = relative(c.x_nom[i], v[16 + i]);
            double r = rv > rx ? rv : rx;
            if (r > worst) {
                worst = r;
            }
            if (!(r <= TOLERANCE)) {
                if (bad < 5) {
                    fprintf(stderr, "sample %ld axis %d: voltage %.17g vs %.17g, x_nom %.17g vs %.17g\n",
                            n, i + 1, c.voltage[i], v[14 + i], c.x_nom[i], v[16 + i]);
                }
                bad++;
            }
        }
        if (c.saturated != (v[18] != 0.0) || c.dropout != (v[19] != 0.0)) {
            if (bad < 5) {
                fprintf(stderr, "sample %ld: saturated %d vs %g, dropout %d vs %g\n", n,
                        c.saturated, v[18], c.dropout, v[19]);
            }
            bad++;
        }
        n++;
    }
    fclose(f);
    printf("%s: %ld samples, largest relative difference %.3g, %ld outside 1e-12\n",
           NAME(CONTROLLER), n, worst, bad);
    return bad == 0 && n > 0 ? 0 : 1;
}
