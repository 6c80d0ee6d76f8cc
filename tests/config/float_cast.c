/*
 * Under DKF_SANITIZE the sanitizers must stop a double-to-integer cast out
 * of range (C99 6.3.1.4: undefined): the ctest sanitize_float_cast_overflow
 * expects this program to be stopped with UBSan's report.
 */
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv)
{
    /* from the command line, so the compiler cannot fold the cast */
    const double v = argc > 1 ? strtod(argv[1], NULL) : 0.0;
    const long long n = (long long)v;
    printf("%lld\n", n);
    return 0;
}
