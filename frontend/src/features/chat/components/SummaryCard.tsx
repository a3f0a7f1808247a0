import { StatusChip } from '@/components/ui/StatusChip';
import { PlanList } from '@/features/mission/components/PlanStep';
import type { FeedItem, MissionUsage } from '@/stores/chatStore';
import type { MissionState } from '@/stores/missionStore';

type Summary = Extract<FeedItem, { kind: 'summary' }>;

/** mission_finished: the panel collapses into this card in the conversation feed. */
export function SummaryCard({ item }: { item: Summary }) {
  return (
    <article aria-label={`Mission summary ${item.missionId}`} className="rounded-lg border border-line bg-surface px-3 py-2">
      <header className="flex items-center gap-2">
        <h3 className="min-w-0 flex-1 truncate text-sm font-semibold">{item.instruction || 'Mission'}</h3>
        <StatusChip state={item.outcome as MissionState} />
      </header>
      {item.summary && <p className="mt-1 text-sm">{item.summary}</p>}
      {item.usage && <UsageLine usage={item.usage} />}
      {item.steps.length > 0 && (
        <details className="mt-1">
          <summary className="cursor-pointer text-xs text-muted">{item.steps.length} steps</summary>
          <div className="mt-1">
            <PlanList steps={item.steps} label="Final plan" compact />
          </div>
        </details>
      )}
    </article>
  );
}

/** Planner tokens and cost, e.g. "Planner: 42,100 tokens · $0.15"; nothing for the offline planner. */
function UsageLine({ usage }: { usage: MissionUsage }) {
  const tokens = (usage.input_tokens ?? 0) + (usage.output_tokens ?? 0);
  if (tokens === 0 && !usage.cost_usd) return null;
  const cost = usage.cost_usd != null ? ` · $${usage.cost_usd.toFixed(2)}` : '';
  return <p className="mt-1 text-xs text-muted">{`Planner: ${tokens.toLocaleString('en-US')} tokens${cost}`}</p>;
}
