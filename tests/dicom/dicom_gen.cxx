/*
 * tests/dicom/dicom_gen.cxx — writes DICOM series of known volumes with
 * GDCM's own writer (gdcm::ImageWriter, gdcm::ImageChangeTransferSyntax),
 * for tests/unit/test_dicom.c and the load-time measurement. Test-only.
 *
 *   volux_dicom_gen CASE OUTDIR
 *
 * The volume of every case: value(i,j,k) = (7i + 13j + 101k) mod 4000
 * (stored, 12 bits in 16), 20x16x12, pixel spacing 0.7 (x) / 0.8 (y),
 * slices 2.5 mm apart, origin (-10, -20, 30), CT, rescale 1/-1024. Files
 * are named so that name order is not slice order (s%02d = 7k mod 12) and
 * InstanceNumber runs backwards, so only positions give the order.
 * Cases: ct, ct-rle, ct-jpegls, ct-j2k, ct-jpeg (lossless), sag (row
 * (0,1,0), column (0,0,-1)), scale (signed 16 bit, slope 0.5, intercept
 * 10), two (ct + a 3-slice 8x8 MR series), missing (k=5 left out), mixed
 * (k=3 is 10 wide), tilt (slice k shifted 0.5k mm along y), dup (k=4 at
 * k=3's position), truncated (k=6's file cut to 60 %), multi (one
 * multi-frame file), big (512x512x300 procedural CT, for timing).
 */
#include <gdcmAttribute.h>
#include <gdcmImage.h>
#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageWriter.h>
#include <gdcmMediaStorage.h>
#include <gdcmTrace.h>
#include <gdcmUIDGenerator.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

struct Series {
    int nx = 20, ny = 16, nz = 12;
    double sx = 0.7, sy = 0.8, step = 2.5;
    double origin[3] = {-10, -20, 30};
    double dircos[6] = {1, 0, 0, 0, 1, 0};
    bool is_signed = false;
    int bits_stored = 12;
    double slope = 1, intercept = -1024;
    std::string uid, modality = "CT", prefix = "s";
    gdcm::MediaStorage::MSType ms = gdcm::MediaStorage::CTImageStorage;
    gdcm::TransferSyntax::TSType ts = gdcm::TransferSyntax::ExplicitVRLittleEndian;
    bool big = false;
};

int value(int i, int j, int k) { return (7 * i + 13 * j + 101 * k) % 4000; }

void put(gdcm::DataSet &ds, uint16_t g, uint16_t e, gdcm::VR vr, std::string v) {
    if (v.size() % 2) v += vr == gdcm::VR::UI ? '\0' : ' ';
    gdcm::DataElement de(gdcm::Tag(g, e));
    de.SetVR(vr);
    de.SetByteValue(v.data(), (uint32_t)v.size());
    ds.Replace(de);
}

double big_value(int i, int j, int k, int n) {
    /* a body (water, 0 HU) with a bone ring and air outside: HU + 1024 */
    double x = (i - n / 2.0) / (n / 2.0), y = (j - n / 2.0) / (n / 2.0), z = (k - 150) / 150.0;
    double r = std::sqrt(x * x + y * y * 1.4 + 0.2 * z * z);
    if (r > 0.9) return 0;
    if (r > 0.8) return 1024 + 1200;
    return 1024 + 40 + 30 * std::sin(9 * x) * std::cos(7 * y);
}

bool write_image(const Series &s, const std::string &path, int first_k, int frames, int width, const double pos[3],
                 int instance) {
    gdcm::ImageWriter w;
    gdcm::Image &im = w.GetImage();
    im.SetNumberOfDimensions(frames > 1 ? 3 : 2);
    im.SetDimension(0, (unsigned)width);
    im.SetDimension(1, (unsigned)s.ny);
    if (frames > 1) im.SetDimension(2, (unsigned)frames);
    gdcm::PixelFormat pf(1, 16, (unsigned short)s.bits_stored, (unsigned short)(s.bits_stored - 1),
                         s.is_signed ? 1 : 0);
    im.SetPixelFormat(pf);
    im.SetPhotometricInterpretation(gdcm::PhotometricInterpretation::MONOCHROME2);
    im.SetSpacing(0, s.sx);
    im.SetSpacing(1, s.sy);
    if (frames > 1) im.SetSpacing(2, s.step);
    for (int c = 0; c < 3; c++) im.SetOrigin((unsigned)c, pos[c]);
    im.SetDirectionCosines(s.dircos);
    im.SetIntercept(s.intercept);
    im.SetSlope(s.slope);
    std::vector<uint16_t> px((size_t)width * (size_t)s.ny * (size_t)frames);
    size_t w_i = 0;
    for (int f = 0; f < frames; f++)
        for (int j = 0; j < s.ny; j++)
            for (int i = 0; i < width; i++) {
                int k = first_k + f;
                double v = s.big ? big_value(i, j, k, width) : value(i, j, k);
                if (s.is_signed) v -= 1500;
                px[w_i++] = (uint16_t)(int16_t)(int)v;
            }
    gdcm::DataElement pd(gdcm::Tag(0x7fe0, 0x0010));
    pd.SetByteValue(reinterpret_cast<const char *>(px.data()), (uint32_t)(px.size() * 2));
    im.SetDataElement(pd);
    im.SetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
    gdcm::DataSet &ds = w.GetFile().GetDataSet();
    put(ds, 0x0008, 0x0016, gdcm::VR::UI, gdcm::MediaStorage::GetMSString(s.ms));
    put(ds, 0x0008, 0x0060, gdcm::VR::CS, s.modality);
    put(ds, 0x0008, 0x103e, gdcm::VR::LO, s.prefix == "s" ? "volux test" : "second series");
    put(ds, 0x0020, 0x000d, gdcm::VR::UI, "1.2.826.0.1.3680043.2.1125.1.1");
    put(ds, 0x0020, 0x000e, gdcm::VR::UI, s.uid);
    put(ds, 0x0020, 0x0011, gdcm::VR::IS, s.prefix == "s" ? "3" : "7");
    put(ds, 0x0020, 0x0013, gdcm::VR::IS, std::to_string(instance));
    if (s.ts != gdcm::TransferSyntax::ExplicitVRLittleEndian) {
        gdcm::ImageChangeTransferSyntax change;
        change.SetTransferSyntax(gdcm::TransferSyntax(s.ts));
        change.SetInput(im);
        if (!change.Change()) {
            std::fprintf(stderr, "cannot change the transfer syntax\n");
            return false;
        }
        w.SetImage(change.GetOutput());
    }
    w.SetFileName(path.c_str());
    if (!w.Write()) {
        std::fprintf(stderr, "cannot write %s\n", path.c_str());
        return false;
    }
    return true;
}

std::string name_of(const Series &s, const std::string &dir, int k) {
    char b[32];
    std::snprintf(b, sizeof b, "%s%02d.dcm", s.prefix.c_str(), (7 * k) % s.nz); /* a permutation: 7 is prime to 12 and 300 */
    return dir + "/" + b;
}

void position(const Series &s, int k, double out[3]) {
    const double *r = s.dircos, *c = s.dircos + 3;
    double n[3] = {r[1] * c[2] - r[2] * c[1], r[2] * c[0] - r[0] * c[2], r[0] * c[1] - r[1] * c[0]};
    for (int a = 0; a < 3; a++) out[a] = s.origin[a] + k * s.step * n[a];
}

bool write_series(const Series &s, const std::string &dir, const std::string &kase) {
    for (int k = 0; k < s.nz; k++) {
        if (kase == "missing" && k == 5) continue;
        double pos[3];
        position(s, k, pos);
        if (kase == "tilt") pos[1] += 0.5 * k;
        if (kase == "dup" && k == 4) position(s, 3, pos);
        int width = kase == "mixed" && k == 3 ? 10 : s.nx;
        std::string path = name_of(s, dir, k);
        if (!write_image(s, path, k, 1, width, pos, s.nz - k)) return false;
        if (kase == "truncated" && k == 6) {
            FILE *f = std::fopen(path.c_str(), "rb");
            std::vector<char> b(1 << 20);
            size_t n = std::fread(b.data(), 1, b.size(), f);
            std::fclose(f);
            f = std::fopen(path.c_str(), "wb");
            std::fwrite(b.data(), 1, n * 6 / 10, f);
            std::fclose(f);
        }
    }
    return true;
}

} // namespace

int main(int argc, char **argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: volux_dicom_gen CASE OUTDIR\n");
        return 2;
    }
    std::string kase = argv[1], dir = argv[2];
    gdcm::Trace::SetWarning(false); /* "no PhotometricInterpretation found" while the image is being built */
    gdcm::Trace::SetDebug(false);
    Series s;
    s.uid = "1.2.826.0.1.3680043.2.1125.1.2";
    if (kase == "ct-rle") s.ts = gdcm::TransferSyntax::RLELossless;
    else if (kase == "ct-jpegls") s.ts = gdcm::TransferSyntax::JPEGLSLossless;
    else if (kase == "ct-j2k") s.ts = gdcm::TransferSyntax::JPEG2000Lossless;
    else if (kase == "ct-jpeg") s.ts = gdcm::TransferSyntax::JPEGLosslessProcess14_1;
    else if (kase == "sag") {
        double d[6] = {0, 1, 0, 0, 0, -1};
        std::memcpy(s.dircos, d, sizeof d);
    } else if (kase == "scale") {
        s.is_signed = true;
        s.bits_stored = 16;
        s.slope = 0.5;
        s.intercept = 10;
    } else if (kase == "multi") {
        s.ms = gdcm::MediaStorage::EnhancedCTImageStorage;
        double pos[3];
        position(s, 0, pos);
        return write_image(s, dir + "/multi.dcm", 0, s.nz, s.nx, pos, 1) ? 0 : 1;
    } else if (kase == "big") {
        s.nx = s.ny = 512;
        s.nz = 300;
        s.sx = s.sy = 0.7;
        s.step = 1.0;
        s.big = true;
    } else if (kase != "ct" && kase != "two" && kase != "missing" && kase != "mixed" && kase != "tilt" &&
               kase != "dup" && kase != "truncated") {
        std::fprintf(stderr, "volux_dicom_gen: unknown case '%s'\n", kase.c_str());
        return 2;
    }
    if (!write_series(s, dir, kase)) return 1;
    if (kase == "two") {
        Series b;
        b.uid = "1.2.826.0.1.3680043.2.1125.1.3";
        b.nx = b.ny = 8;
        b.nz = 3;
        b.prefix = "mr";
        b.modality = "MR";
        b.ms = gdcm::MediaStorage::MRImageStorage;
        b.intercept = 0;
        if (!write_series(b, dir, "two")) return 1;
    }
    return 0;
}
