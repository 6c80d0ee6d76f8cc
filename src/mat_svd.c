/* placeholder: being written */
typedef int dkf_placeholder_mat_svd_t;
