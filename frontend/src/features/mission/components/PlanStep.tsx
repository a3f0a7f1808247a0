import { STATUS_TEXT } from '@/components/ui/StatusChip';
import type { Step, StepStatus } from '@/stores/missionStore';

const ICON: Record<StepStatus, string> = {
  pending: '○',
  running: '●',
  succeeded: '✓',
  failed: '✕',
  skipped: '–',
};

const LABEL: Record<StepStatus, string> = {
  pending: 'pending',
  running: 'running',
  succeeded: 'done',
  failed: 'failed',
  skipped: 'skipped',
};

/** One plan step: the five status treatments (spec §11.2), colours from semantic tokens. */
export function PlanStep({ step, compact = false }: { step: Step; compact?: boolean }) {
  const tone = STATUS_TEXT[step.status];
  const running = step.status === 'running';
  return (
    <li
      data-step-id={step.id}
      data-status={step.status}
      data-kind={step.tool?.startsWith('manipulation.') ? 'arm' : undefined}
      aria-label={`${step.title}: ${LABEL[step.status]}`}
      className={`relative flex gap-3 rounded-md border border-line px-3 ${compact ? 'py-1' : 'py-2'}
        ${running ? 'shimmer border-status-running' : ''} ${step.status === 'failed' ? 'border-status-failed' : ''}
        ${step.isNew ? 'animate-step-in' : ''}`}
    >
      <span aria-hidden="true" className={`mt-0.5 w-4 shrink-0 text-center font-bold ${tone} ${running ? 'animate-pulse' : ''}`}>
        {ICON[step.status]}
      </span>
      <div className="min-w-0 flex-1">
        <div className="flex flex-wrap items-baseline gap-x-2">
          <span className={`text-sm font-medium ${step.status === 'skipped' ? 'text-muted line-through' : ''}`}>
            {step.title}
          </span>
          {step.tool?.startsWith('manipulation.') && (
            <span className="rounded border border-line px-1 text-[10px] uppercase tracking-wide text-muted">arm</span>
          )}
          {step.tool && !compact && <code className="truncate text-xs text-muted">{step.tool}</code>}
          <span className={`ml-auto text-xs font-semibold ${tone}`}>{LABEL[step.status]}</span>
        </div>
        {step.detail && !compact && (
          <p className={`mt-0.5 text-xs break-words ${step.status === 'failed' ? tone : 'text-muted'}`}>{step.detail}</p>
        )}
      </div>
    </li>
  );
}

export function PlanList({ steps, label, compact = false }: { steps: Step[]; label: string; compact?: boolean }) {
  return (
    <ol aria-label={label} className="flex flex-col gap-1.5">
      {steps.map((step) => (
        <PlanStep key={step.id} step={step} compact={compact} />
      ))}
    </ol>
  );
}
