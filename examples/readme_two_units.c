/*
 * Driver of the ctest readme_two_units (examples/CMakeLists.txt): the
 * README's first C block compiled twice, as two files of one program, with
 * its main renamed to dkf_readme_main_a / _b. Linking proves that the
 * README's file-scope DKF_*_DECLARE(static, ...) objects stay private to
 * each file (the old `static DKF_KF_DECLARE(kf, 4, 2);` left `kf`
 * external: "multiple definition of `kf`"); running both proves each file
 * has its own filter (the second run starts from its own prior, not from
 * the first one's end state, so both print the same estimate).
 */
int dkf_readme_main_a(void);
int dkf_readme_main_b(void);

int main(void)
{
    int a = dkf_readme_main_a();
    int b = dkf_readme_main_b();
    return a == 0 && b == 0 ? 0 : 1;
}
