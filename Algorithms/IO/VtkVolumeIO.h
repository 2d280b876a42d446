#pragma once
// Volume formats read and written through VTK (no VTK header leaks out of this file).
//
// Physical frame: TetFlow's physical coordinates follow the LPS convention of ITK, DICOM,
// MetaImage and NRRD's "left-posterior-superior" space. NIfTI stores RAS, so its q-/s-form is
// converted on read (x and y negated) and back on write. That way one segmentation saved as
// .nii.gz, .mha, .nrrd and .inr by ITK-based tools reads with the same origin and axes.
//
//  NIfTI (.nii, .nii.gz): vtkNIFTIImageReader; the q-form (when qform_code > 0) or else the s-form
//     gives origin and axis directions (slice order is handled by VTK's qfac logic); scl_slope /
//     scl_inter are applied when they are not the identity. Written with vtkNIFTIImageWriter
//     (q-form, or s-form for a left-handed grid).
//  MetaImage (.mha, .mhd): vtkMetaImageReader for the voxels; our own header scan checks sizes
//     before VTK allocates, and applies TransformMatrix (ITK writes it as the axis directions one
//     after another: TransformMatrix[3a + r] = direction[r][a]). Written with vtkMetaImageWriter
//     (axis-aligned grids only: it has no field for axis directions).
//  VTK XML image (.vti): vtkXMLImageDataReader/Writer including the Direction attribute.
#include <string>

#include "RawVolume.h"

namespace tetflow {

RawVolume readNifti(const std::string& path);
RawVolume readMetaImage(const std::string& path);
RawVolume readVti(const std::string& path);

void writeNifti(const std::string& path, const RawVolume& v);     // .nii or .nii.gz
void writeMetaImage(const std::string& path, const RawVolume& v); // .mha (one file) or .mhd + .raw/.zraw
void writeVti(const std::string& path, const RawVolume& v);

} // namespace tetflow
