/* placeholder: being written */
typedef int dkf_placeholder_mat_chol_t;
