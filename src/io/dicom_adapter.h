/*
 * io/dicom_adapter.h — the C ABI of the one C++ file in the project
 * (dicom_gdcm.cxx), which asks GDCM (Debian's libgdcm-dev, DESIGN §5) what
 * one DICOM file holds and decodes its pixels. Everything DICOM-specific
 * that is policy — which files make a series, slice order, spacing, the
 * checks and the messages — lives in C (dicom.c); the adapter only reads.
 *
 * A file is read from `path`, or from memory when `mem` is non-NULL (the
 * fuzz harness and tests). Neither function throws, prints (GDCM's own
 * warning streams are silenced) or keeps the file open. `msg` receives a
 * short reason (no file name: the caller adds it) when the result is not
 * VOLUX_DICOM_OK.
 *
 * Built only when GDCM is found (VOLUX_HAVE_GDCM); without it dicom.c says
 * that DICOM support was not built.
 */
#ifndef VOLUX_IO_DICOM_ADAPTER_H
#define VOLUX_IO_DICOM_ADAPTER_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#define VOLUX_DICOM_TEXT 72

enum {
    VOLUX_DICOM_OK = 0,
    VOLUX_DICOM_NOT_DICOM = 1, /* GDCM cannot parse it as DICOM at all */
    VOLUX_DICOM_NO_IMAGE = 2,  /* DICOM, but no image (DICOMDIR, report, ...) */
    VOLUX_DICOM_BAD = 3        /* an image that cannot be decoded: msg says why */
};

typedef struct volux_dicom_info {
    char series_uid[VOLUX_DICOM_TEXT];  /* (0020,000E) */
    char description[VOLUX_DICOM_TEXT]; /* (0008,103E) */
    char modality[VOLUX_DICOM_TEXT];    /* (0008,0060) */
    char transfer_syntax[VOLUX_DICOM_TEXT];
    int series_number;   /* (0020,0011), 0 when absent */
    int instance_number; /* (0020,0013) */
    int has_instance;
    int columns, rows, frames; /* frames ≥ 1 (NumberOfFrames) */
    int samples;               /* samples per pixel */
    int bits_allocated, bits_stored;
    int pixel_signed, pixel_float;
    /* Image Position (Patient) of the first frame, LPS millimetres. */
    double position[3];
    int has_position;
    /* Image Orientation (Patient): row direction (along a row, increasing
     * column index), then column direction. */
    double orientation[6];
    int has_orientation;
    /* Pixel spacing as x (between columns), y (between rows); z is the
     * spacing between frames of a multi-frame file (GDCM derives it from
     * the per-frame positions, SpacingBetweenSlices or the
     * GridFrameOffsetVector), else 0. */
    double spacing[3];
    double slope, intercept; /* Rescale Slope/Intercept (1, 0 when absent) */
    double gantry_tilt;      /* (0018,1120) degrees, 0 when absent */
} volux_dicom_info;

/* Reads the header (up to the pixel data) of one file. */
int volux_dicom_adapter_info(const char *path, const void *mem, size_t n, volux_dicom_info *out, char *msg,
                             size_t msg_size);

/* Decodes the pixel data of one file (any transfer syntax GDCM decodes:
 * uncompressed, deflate, RLE, JPEG baseline/lossless, JPEG-LS, JPEG 2000)
 * into buf, which must hold exactly `bytes` = columns·rows·frames·samples·
 * bits_allocated/8 (host byte order). A different decoded size is
 * VOLUX_DICOM_BAD. */
int volux_dicom_adapter_pixels(const char *path, const void *mem, size_t n, void *buf, size_t bytes, char *msg,
                               size_t msg_size);

#ifdef __cplusplus
}
#endif

#endif
