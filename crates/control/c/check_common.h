/* What both checks of an exported controller share (check.c, check_backstepping.c): the
 * controller's names from its prefix CONTROLLER, the tolerance, reading the recorded sequence
 * and comparing a command with the recorded one. Include after CONTROLLER_H. */
#ifndef FLEXSTAGE_CHECK_COMMON_H
#define FLEXSTAGE_CHECK_COMMON_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#define CAT(a, b) a##b
#define NAMED(a, b) CAT(a, b)
#define STATE NAMED(CONTROLLER, _state)
#define COMMAND NAMED(CONTROLLER, _command)
#define INIT NAMED(CONTROLLER, _init)
#define STEP NAMED(CONTROLLER, _step)
#define STR(a) #a
#define NAME(a) STR(a)

#define TOLERANCE 1e-12

/* The tally of a check: samples compared, samples or flags outside the tolerance, the largest
 * relative difference. */
struct tally {
    long n, bad;
    double worst;
};

static double relative(double c, double r)
{
    double d = fabs(c - r);
    if (d == 0.0) {
        return 0.0;
    }
    return r == 0.0 ? INFINITY : d / fabs(r);
}

/* The sequence file of the command line, its header line read into `line`; NULL (after a
 * message) on a wrong command line or an unreadable file. */
static FILE *open_sequence(int argc, char **argv, char *line, int size)
{
    FILE *f;
    if (argc != 2) {
        fprintf(stderr, "usage: %s SEQUENCE.csv\n", argv[0]);
        return NULL;
    }
    f = fopen(argv[1], "r");
    if (f == NULL || fgets(line, size, f) == NULL) {
        fprintf(stderr, "cannot read %s\n", argv[1]);
        return NULL;
    }
    return f;
}

/* The first `columns` comma-separated numbers of `p` into `v`; 0, or -1 (after a message
 * naming `line` and the column) if one is not a number. */
static int read_columns(const char *p, double *v, int columns, long line)
{
    char *end;
    int i;
    for (i = 0; i < columns; i++) {
        v[i] = strtod(p, &end);
        if (end == p) {
            fprintf(stderr, "line %ld: column %d is not a number\n", line, i + 1);
            return -1;
        }
        p = end;
        if (*p == ',') {
            p++;
        }
    }
    return 0;
}

/* Sample `n`'s voltages and x_nom against the recorded ones (`voltage`, `x_nom`: two axes
 * each) to TOLERANCE relative; the first five differences are printed. */
static void compare_command(struct tally *t, const double voltage[2], const double x_nom[2],
                            const double *recorded_voltage, const double *recorded_x_nom)
{
    int i;
    for (i = 0; i < 2; i++) {
        double rv = relative(voltage[i], recorded_voltage[i]);
        double rx = relative(x_nom[i], recorded_x_nom[i]);
        double r = rv > rx ? rv : rx;
        if (r > t->worst) {
            t->worst = r;
        }
        if (!(r <= TOLERANCE)) {
            if (t->bad < 5) {
                fprintf(stderr, "sample %ld axis %d: voltage %.17g vs %.17g, x_nom %.17g vs %.17g\n",
                        t->n, i + 1, voltage[i], recorded_voltage[i], x_nom[i],
                        recorded_x_nom[i]);
            }
            t->bad++;
        }
    }
}

/* Prints the tally; the exit status: 0 only if every sample agreed and there was one. */
static int finish(const struct tally *t)
{
    printf("%s: %ld samples, largest relative difference %.3g, %ld outside 1e-12\n",
           NAME(CONTROLLER), t->n, t->worst, t->bad);
    return t->bad == 0 && t->n > 0 ? 0 : 1;
}

#endif
