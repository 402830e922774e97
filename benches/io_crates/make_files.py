"""The VTK-written test files of io_crates: the vmtk aorta's reference surface in every mode
of VTK's mesh writers, the aorta volume as .vti and legacy .vtk, and small ones for the
mutation runs (small/). Run by make_files.sh with VTK's Python package."""
import sys
import vtk

data, out = sys.argv[1], sys.argv[2]
MODES = ["ascii", "binary", "appended"]


def xml(writer, dataset, name, mode, compress=True):
    w = writer()
    w.SetInputData(dataset)
    w.SetFileName(name)
    {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary,
     "appended": w.SetDataModeToAppended}[mode]()
    if mode == "appended":
        w.EncodeAppendedDataOff()
    if not compress:
        w.SetCompressorTypeToNone()
    w.Write()


def legacy(writer, dataset, name, ascii, big_endian=None):
    w = writer()
    w.SetInputData(dataset)
    w.SetFileName(name)
    w.SetFileTypeToASCII() if ascii else w.SetFileTypeToBinary()
    if big_endian is not None:
        w.SetDataByteOrderToBigEndian() if big_endian else w.SetDataByteOrderToLittleEndian()
    w.Write()


def every_mode(poly, img, prefix, image_prefix):
    for mode in MODES:
        xml(vtk.vtkXMLPolyDataWriter, poly, f"{prefix}-{mode}.vtp", mode)
        xml(vtk.vtkXMLImageDataWriter, img, f"{image_prefix}-{mode}.vti", mode)
    for ascii, kind in [(True, "ascii"), (False, "binary")]:
        legacy(vtk.vtkPolyDataWriter, poly, f"{prefix}-{kind}.vtk", ascii)
        legacy(vtk.vtkSTLWriter, poly, f"{prefix}-{kind}.stl", ascii)
        legacy(vtk.vtkStructuredPointsWriter, img, f"{image_prefix}-{kind}.vtk", ascii)


reader = vtk.vtkXMLPolyDataReader()
reader.SetFileName(f"{data}/vmtk-aorta/aorta-reference-surface.vtp")
reader.Update()
meta = vtk.vtkMetaImageReader()
meta.SetFileName(f"{data}/vmtk-aorta/aorta.mha")
meta.Update()
poly, img = reader.GetOutput(), meta.GetOutput()
every_mode(poly, img, f"{out}/ref", f"{out}/aorta")
xml(vtk.vtkXMLPolyDataWriter, poly, f"{out}/ref-binary-raw.vtp", "binary", compress=False)
legacy(vtk.vtkPLYWriter, poly, f"{out}/ref-ascii.ply", True)
legacy(vtk.vtkPLYWriter, poly, f"{out}/ref-binary-le.ply", False, big_endian=False)
legacy(vtk.vtkPLYWriter, poly, f"{out}/ref-binary-be.ply", False, big_endian=True)

sphere = vtk.vtkSphereSource()
sphere.SetThetaResolution(8)
sphere.SetPhiResolution(6)
sphere.Update()
small = vtk.vtkImageData()
small.SetDimensions(6, 5, 4)
small.SetSpacing(0.5, 1, 2)
small.SetOrigin(1, 2, 3)
small.AllocateScalars(vtk.VTK_SHORT, 1)
for i in range(120):
    small.GetPointData().GetScalars().SetValue(i, i * 7 - 300)
every_mode(sphere.GetOutput(), small, f"{out}/small/vtk", f"{out}/small/vtk-image")
legacy(vtk.vtkPLYWriter, sphere.GetOutput(), f"{out}/small/vtk-ascii.ply", True)
legacy(vtk.vtkPLYWriter, sphere.GetOutput(), f"{out}/small/vtk-binary.ply", False)
