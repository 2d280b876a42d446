# Test tiers (docs/installing.md "Tests: three tiers"). Every CTest test carries exactly one of
#   unit         one algorithm or one piece of the engine on small cases: exact answers,
#                invariants, error messages; seconds each;
#   integration  a net, the command line, the node editor or a whole pipeline end to end on small
#                inputs (random volumes, phantoms, the bundled 4 mm head);
#   study        large inputs, convergence tables, peer comparisons: not in CI, run with
#                `scripts/setup.sh --test --all` (or `ctest -L study`).
# An integration test also carries `memory` unless it is listed in TETFLOW_RELEASE_ONLY_TESTS:
# the sanitizer half of CI runs `unit` and `memory` (the readers, cleaving, repair, surfaces and
# solvers under ASan + UBSan).
#
# A GoogleTest test not named here is a unit test. Entries are GoogleTest filter patterns
# (`*` any characters, `?` one); they also apply to the tests Testing/CMakeLists.txt adds by hand
# (Nets.NAME for each shipped net, Gui.*). Repository.EveryTestHasATier fails when a test has no
# tier or two, or when an entry here matches no test.

# The studies, each with the smaller test of the same code path that keeps its bound in CI.
set(TETFLOW_STUDY_TESTS
  # the 2 mm layered head through default.srn and adaptive_head.srn (65 s); in CI: the same on the
  # bundled 4 mm head, Nets.TheHeadNetsPassTheirCertificatesOnTheBundled4mmHead
  Nets.TheHeadNetsPassTheirCertificatesOnALayeredHead
  # the default net three times, on one and two threads (61 s); in CI: on a smaller phantom,
  # Cli.ASmallerDefaultNetIsDeterministicAcrossThreadCountsAndRuns
  Cli.TheDefaultNetIsDeterministicAcrossThreadCountsAndRuns
  # every background from NIfTI and from NRRD: six meshings of the 4 mm head (56 s); in CI: four,
  # MeshCommand.EachBackgroundMeshesTheBundledHeadAndNiftiAndNrrdGiveOneMesh
  MeshCommand.EachBackgroundMeshesTheBundledHeadTheSameFromNiftiAndNrrd
  # the four-shell sphere's errors at 4 and 3 mm lattices (43 s); in CI: the 4 mm bounds,
  # EegForward.FourShellSphereErrorsAtA4mmLatticeStayWithinTheirBounds
  EegForward.FourShellSphereErrorsFallWithTheLattice
  # the bem_head net's surfaces checked by MNE-Python, a peer (27 s); in CI: on a smaller phantom,
  # ExtractSurfacesModule.ASmallerHeadsBemSurfacesPassTheirChecksAndMnes
  ExtractSurfacesModule.TheBemHeadNetsSurfacesPassTheirChecksAndMnes
)

set(TETFLOW_INTEGRATION_TESTS
  # the shipped nets (Nets.NAME), the headless runner, `tetflow mesh`, the node editor
  Nets.* Cli.* CliProgress.* MeshCommand.* Gui.*
  # the examples of the README and docs/, run as a user would copy them
  DocumentationExamples.*
  # modules run by the executor in nets of their own
  *Module.* EvaluateQualityFixture.* CadModulesFixture.* EegForward.* MegModules.*
  TissueNamesPipeline.* GmshMeshPipeline.*
  # whole meshing pipelines (background, cleave, repair, correction, improvement) on random
  # segmentations and phantoms, and the CAD mesher from model to tets
  Fidelity.*
  Cleaver.RandomLabelVolumesGiveValidConformingMeshes
  Cleaver.HeadPhantomVolumesConvergeAndInterfacesLieOnTheSpheres
  Particles.CleavingOnParticleBackgroundsGivesValidConformingMeshes
  MeshImprovement.RandomLabelVolumesReachTheTargetsAndKeepTheirLabels
  LabelRepair.CleavedRandomVolumesLoseTheirForbiddenContactsAndKeepTheirGeometry
  CadMesher.*
)

# Integration tests the sanitizer half leaves out (they run in the Release half), each because
# smaller tests of the same code run under the sanitizers.
set(TETFLOW_RELEASE_ONLY_TESTS
  # Qt and VTK rendering: not built in the sanitizer half
  Gui.*
  # timing of a terminal's live line (55 s under ASan); the progress events themselves run under
  # the sanitizers in CliProgress.JsonlEventsComeInOrderWithEachStageRisingToOne
  CliProgress.OnATerminalALiveLineFollowsTheRunningModuleAndGivesWayToItsSummary
  # the same meshing code on larger inputs or more often; under the sanitizers it runs in
  # Nets.default, Nets.mesh_labels_adaptive, Nets.spheres, Fidelity.RandomSegmentations*,
  # CleaveMeshModule.* and Particles.*
  Nets.adaptive_particles
  Nets.adaptive_head
  Nets.mesh_labels
  Nets.ANetOfDefaultModulesIsAsFaithfulAsTheShippedOnes
  Nets.TheHeadNetsPassTheirCertificatesOnTheBundled4mmHead
  Cli.ASmallerDefaultNetIsDeterministicAcrossThreadCountsAndRuns
  MeshCommand.EachBackgroundMeshesTheBundledHeadAndNiftiAndNrrdGiveOneMesh
  MeshCommand.PrintsTheSizesItChoseAndSaveNetReRunsToTheSameMesh
  # five `tetflow mesh` runs of the 4 mm head (28 s); the budget's fit and refusals run under the
  # sanitizers in TetBudget.*
  MeshCommand.MaxTetsKeepsTheMeshWithinItsBudgetOrNamesTheLayer
  # the documentation's commands (`tetflow mesh`, `run`, `certify` on the bundled inputs); the
  # same runner and modules run under the sanitizers in Cli.*, Nets.default and Nets.spheres
  DocumentationExamples.*
  Fidelity.TheAdaptiveDefaultsKeepEveryComponentOfAFiveLabelSegmentation
  Fidelity.CullingTheExteriorLeavesTheMeshAsItWas
  # surfaces of larger heads, and MNE's checks of them (a Python peer); the surface code runs
  # under the sanitizers in ExtractSurfacesModule.TheHeadPhantomsBemSurfaces* and
  # ExtractSurfacesModule.WithoutRepairThePinchedPhantomIsRefused
  Nets.bem_head
  ExtractSurfacesModule.ASmallerHeadsBemSurfacesPassTheirChecksAndMnes
  # forward accuracy on finer meshes (numerics, not memory); the assembly, the solvers and every
  # source model run under the sanitizers in EegForward.*LeadFieldEqualsDirect*Solves,
  # MegModules.* and Nets.head_dipole
  EegForward.VenantBeatsPartialIntegrationAtHighEccentricity
  EegForward.FourShellSphereErrorsAtA4mmLatticeStayWithinTheirBounds
  Nets.eeg_leadfield
  Nets.meg_sphere
  # the smooth-sphere CAD net and its solve (52 s under ASan); the CAD mesher runs under the
  # sanitizers in CadMesher.* (CadMesher.FourShellSphereGivesNestedClosedShellsFillingEachSolid
  # meshes the same four shells), the solvers in EegForward.*LeadFieldEqualsDirect*Solves
  Nets.eeg_sphere_cad
  CadModulesFixture.TheSmoothSphereNetMatchesTheAnalyticPotential
)
