/*
 * techniques/sh/dipole.h — the diffuse reflectance R_d of the dipole
 * approximation (Jensen, Marschner, Levoy & Hanrahan 2001, Eqs. 4–5 and
 * the total R_d of their Eq. for the diffuse reflectance), the measured
 * materials of their Fig. 5 as presets, and the sum-of-Gaussians fit that
 * makes `sh`'s scattering pass (Lindemann & Ropinski 2010, Eq. 4)
 * separable.
 *
 * Units: σ's in 1/mm, r in mm, R_d(r) in 1/mm².
 *
 * DOES NOT: filter volumes (scatter.c does).
 */
#ifndef VOLUX_SH_DIPOLE_H
#define VOLUX_SH_DIPOLE_H

typedef struct sh_dipole_material {
    const char *name;
    double sigma_s_prime[3]; /* reduced scattering, 1/mm, RGB */
    double sigma_a[3];       /* absorption, 1/mm              */
    double eta;              /* relative index of refraction  */
    double rd_published[3];  /* Jensen et al.'s R_d column    */
} sh_dipole_material;

/* The presets: apple, chicken1, chicken2, cream, ketchup, marble, potato,
 * skimmilk, skin1, skin2, spectralon, wholemilk (η = 1.3). */
int sh_dipole_count(void);
const sh_dipole_material *sh_dipole_at(int i);
const sh_dipole_material *sh_dipole_find(const char *name);

/* R_d(r) of channel c (Jensen et al. 2001, Eq. 4 with the dipole of Eq. 5). */
double sh_dipole_rd(const sh_dipole_material *m, int c, double r_mm);
/* Total diffuse reflectance ∫ R_d(r) 2πr dr (closed form). */
double sh_dipole_rd_total(const sh_dipole_material *m, int c);

/* R_d(r) ≈ Σ_k w[c][k] exp(−r²/(2 s_k²)) over r ∈ [0, radius] (world
 * units; mm = world · mm_per_unit), least squares weighted by r² (the
 * shell volume of a 3-D neighbourhood), weights ≥ 0. s_k are fixed,
 * geometric between s_min and s_max. The profile is taken at
 * √(r² + soften²): a core narrower than the grid that samples the kernel
 * (`soften` ≈ half its spacing) cannot be resolved, only its mass. */
#define SH_DIPOLE_GAUSSIANS 4
typedef struct sh_gauss_fit {
    double s[SH_DIPOLE_GAUSSIANS];       /* standard deviations, world units */
    double w[3][SH_DIPOLE_GAUSSIANS];    /* weights per channel             */
    double rel_error[3];                 /* weighted relative L2 error      */
} sh_gauss_fit;
void sh_dipole_fit(const sh_dipole_material *m, double mm_per_unit, double radius, double soften, double s_min,
                   double s_max, sh_gauss_fit *out);

#endif
