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
#define PRIME NAMED(CONTROLLER, _prime)
#define STR(a) #a
#define NAME(a) STR(a)

#define TOLERANCE 1e-12

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
    char line[2048];
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
        double v[12];
        char *p = line, *end;
        int i, columns = 12;
        COMMAND c;
        if (line[0] == 'p' && line[1] == ',') {
            p = line + 2;
            columns = 2;
        }
        for (i = 0; i < columns; i++) {
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
        if (columns == 2) {
            PRIME(&s, &v[0]);
            continue;
        }
        c = STEP(&s, &v[0], &v[2], &v[4], (unsigned long)v[6]);
        /* The recorded command: voltages v[7], v[8], x_nom v[9], v[10], saturated v[11]. */
        for (i = 0; i < 2; i++) {
            double rv = relative(c.voltage[i], v[7 + i]);
            double rx = relative(c.x_nom[i], v[9 + i]);
            double r = rv > rx ? rv : rx;
            if (r > worst) {
                worst = r;
            }
            if (!(r <= TOLERANCE)) {
                if (bad < 5) {
                    fprintf(stderr, "sample %ld axis %d: voltage %.17g vs %.17g, x_nom %.17g vs %.17g\n",
                            n, i + 1, c.voltage[i], v[7 + i], c.x_nom[i], v[9 + i]);
                }
                bad++;
            }
        }
        if (c.saturated != (v[11] != 0.0)) {
            if (bad < 5) {
                fprintf(stderr, "sample %ld: saturated %d vs %g\n", n, c.saturated, v[11]);
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
